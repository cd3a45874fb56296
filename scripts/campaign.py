#!/usr/bin/env python3
"""Monte Carlo and sweep campaigns of walks, on Ray: set up what is missing, then run one.

Usage: ``python3 scripts/campaign.py SPEC`` (a campaign spec, see ``docs/campaigns.md``);
``--help`` lists the options. It runs the spec's walks under their dispersed parameters on a
Ray of its own on this machine (or on a running cluster with ``--address``), streams their
results into ``runs/campaigns/<name>/results.jsonl`` (a second run resumes), and writes the
campaign report next to it.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import walker_env


def main() -> int:
    """Set up, then run :func:`walker_campaign.campaign.main` in the prepared environment."""
    if any(arg in ('-h', '--help') for arg in sys.argv[1:]) and \
            os.environ.get('WALKER_ENV_READY') != '1':
        print(__doc__)
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    from walker_campaign.campaign import main as campaign

    return campaign(sys.argv[1:])


if __name__ == '__main__':
    sys.exit(main())
