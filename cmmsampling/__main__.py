"""``python -m cmmsampling``: see :mod:`cmmsampling.cli`."""
import sys

from .cli import main

sys.exit(main())
