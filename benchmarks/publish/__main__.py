"""`python -m benchmarks.publish [--check]`: render every published text from the results JSON."""
import sys

from benchmarks.publish.render import main

sys.exit(main())
