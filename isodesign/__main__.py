"""``python -m isodesign``: the command line (same as the ``isodesign`` script)."""

import sys

from isodesign.cli import main

sys.exit(main())
