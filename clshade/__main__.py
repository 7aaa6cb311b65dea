"""`python -m clshade` runs the command line."""
import sys

from clshade.cli import run

sys.exit(run())
