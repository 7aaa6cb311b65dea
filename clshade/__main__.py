"""`python -m clshade` runs the command line."""
import sys

from clshade.cli import main

sys.exit(main())
