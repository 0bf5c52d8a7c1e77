"""``python -m hpcgfmd``: see :mod:`hpcgfmd.entry`."""

import sys

from .entry import main

sys.exit(main())
