"""`python -m sensorcfg`: the same command line as `sensorcfg`."""

import sys

from .cli import main

sys.exit(main())
