"""`python -m autopilot` runs the autopilot process (the same as `vtol-autopilot`)."""

import sys

from autopilot.cli import main

sys.exit(main())
