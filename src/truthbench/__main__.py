"""``python -m truthbench``: the command line."""

import sys

from truthbench.cli import main

if __name__ == "__main__":  # not when a spawned worker (Dask) imports this module
    sys.exit(main())
