#!/usr/bin/env python3
"""Set up what is missing, then run walker's whole test suite (unit, integration, linters).

Usage: ``python3 scripts/run_tests.py [pytest arguments]``, e.g. ``-k kinematics`` or ``-x``.
The first run creates ``.venv`` and builds ``ros2_ws``; later runs skip what is current.
"""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import walker_env


def main() -> int:
    """Run pytest over the packages' ``test/`` folders and ``tests/``; return its exit code."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    import pytest

    os.chdir(walker_env.REPO_ROOT)
    started = time.monotonic()
    code = pytest.main(sys.argv[1:])
    print(f'[walker tests] finished in {time.monotonic() - started:.0f} s, exit code {int(code)}')
    return int(code)


if __name__ == '__main__':
    sys.exit(main())
