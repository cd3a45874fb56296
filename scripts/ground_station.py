#!/usr/bin/env python3
"""A robot host and a ground host on this machine (network namespaces), from a clone.

Usage: ``sudo python3 scripts/ground_station.py up|down|cut|restore|degrade|clear|exec ...``
(``--help`` lists them). It runs :func:`walker_bringup.host_link.main` in the project's
environment; docs/ground_station.md shows a session with the graph on the robot host and
walkerctl on the ground host.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import walker_env


def main() -> int:
    """Set up quietly, then run :func:`walker_bringup.host_link.main` in the environment."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:], quiet=True)
    from walker_bringup.host_link import main as ground_station

    return ground_station(sys.argv[1:])


if __name__ == '__main__':
    sys.exit(main())
