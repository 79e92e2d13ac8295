"""`python -m weft.cli ...`: the same as the `weft` command."""

import sys

from weft.cli import app

sys.exit(app())
