#!/usr/bin/env python3
"""walker's main job: set up what is missing, bring up the node graph, walk, record, report.

Usage: ``python3 scripts/run_all.py`` (no arguments needed); ``--help`` lists the options.

It brings the plant, the five joint controllers, the planner, the step-phase supervisor and the
recorder up as separate processes, waits until the graph is ready, walks the robot across the
default truss to a target node, records the walk as a rosbag2 bag, prints a summary per step,
shuts everything down, leaving no process behind, and writes the walk report (figures and an
animation) from the bag.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import walker_env


def main() -> int:
    """Set up, then run :func:`walker_bringup.run.main` in the prepared environment."""
    if any(arg in ('-h', '--help') for arg in sys.argv[1:]) and \
            os.environ.get('WALKER_ENV_READY') != '1':
        print(__doc__)
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    from walker_bringup.run import main as run

    return run(sys.argv[1:])


if __name__ == '__main__':
    sys.exit(main())
