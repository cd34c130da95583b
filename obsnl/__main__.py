"""``python -m obsnl`` runs the command line."""

from obsnl.cli import run

if __name__ == "__main__":  # worker processes (spawn) import this module without running the command line
    run()
