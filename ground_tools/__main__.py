"""`python -m ground_tools` is `vtol`."""

import sys

from ground_tools.cli import main

sys.exit(main())
