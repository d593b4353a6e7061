"""`python -m hpddo SUBCOMMAND ...`: the same as the `hpddo` command."""
import sys

from hpddo.cli import main

if __name__ == "__main__":
    sys.exit(main())
