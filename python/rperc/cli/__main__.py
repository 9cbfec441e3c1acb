import sys

from rperc.cli import main

sys.exit(main())
