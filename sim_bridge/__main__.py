"""`python -m sim_bridge` runs the plant process (the same as `vtol-sim`)."""

import sys

from sim_bridge.cli import main

sys.exit(main())
