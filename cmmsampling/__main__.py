"""``python -m cmmsampling``: see :mod:`cmmsampling.cli`.

Guarded, because a part plan's worker processes start by importing the main module again."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
