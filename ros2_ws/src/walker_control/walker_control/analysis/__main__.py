"""``python -m walker_control.analysis``: the ``control_analysis`` command line."""

import sys

from walker_control.analysis.command import main

sys.exit(main())
