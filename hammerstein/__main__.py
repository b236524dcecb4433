"""``python -m hammerstein``: the same as the ``hammerstein`` console script."""

import sys

from hammerstein.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
