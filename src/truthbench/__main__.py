"""``python -m truthbench``: the command line."""

import sys

from truthbench.cli import main

sys.exit(main())
