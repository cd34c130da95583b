"""``python -m obsnl`` runs the command line."""

import sys

from obsnl.cli import main

if __name__ == "__main__":  # worker processes (spawn) import this module without running the command line
    sys.exit(main())
