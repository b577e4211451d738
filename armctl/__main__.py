"""``python -m armctl``: the command-line interface."""

import sys

from armctl.cli import main

sys.exit(main())
