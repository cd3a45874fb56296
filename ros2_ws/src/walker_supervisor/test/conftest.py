"""Makes the test helpers beside this file importable (the headless world of the runner)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
