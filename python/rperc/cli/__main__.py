"""``python -m rperc.cli``: the ``rperc`` command."""

import sys

from rperc.cli import main

sys.exit(main())
