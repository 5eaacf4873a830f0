"""`python3 -m reference …` from `scripts/`: the same command as scripts/reference_identify.py."""

import sys
import time

_T_START = time.perf_counter()

# No __pycache__ in the source tree, as for scripts/reference_identify.py.
sys.dont_write_bytecode = True

from .cli import main

sys.exit(main(started_s=_T_START))
