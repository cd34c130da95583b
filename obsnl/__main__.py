"""``python -m obsnl`` runs the command line."""

import sys

from obsnl.cli import main

sys.exit(main())
