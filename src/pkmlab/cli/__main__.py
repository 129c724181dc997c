"""``python -m pkmlab.cli``: the ``pkmlab`` executable."""

import sys

from . import entry

sys.exit(entry())
