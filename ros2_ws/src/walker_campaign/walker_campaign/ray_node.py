"""``python -m walker_campaign.ray_node [ray start options]``: a Ray node bound to loopback.

``ray start --node-ip-address 127.0.0.1`` alone does not keep a node on loopback on Linux:
Ray 2.60 replaces a loopback address by the machine's own (``resolve_ip_for_localhost``, so
that other machines can reach the node), and its servers then listen on every interface.
This runs Ray's own ``ray start`` with that replacement left out, so that a node given
``--node-ip-address 127.0.0.1`` advertises and listens on 127.0.0.1 only (checked: the GCS,
the raylet, the object manager and the workers all bind 127.0.0.1). Several such nodes on one
machine form a cluster that nothing outside the machine can reach: the campaign tests and
the benchmark start theirs so. Usage statistics are off.

A cluster over several machines is started with plain ``ray start`` on each (its nodes must
then listen on the network that joins them); see ``docs/campaigns.md``.
"""

from __future__ import annotations

import os
import sys

__all__ = ['main', 'LOOPBACK']

LOOPBACK = '127.0.0.1'


def main(argv: list[str] | None = None) -> int:
    """Run ``ray start`` with ``argv``, keeping a loopback node address as given."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if '--node-ip-address' not in argv:
        argv = ['--node-ip-address', LOOPBACK, *argv]
    os.environ['RAY_USAGE_STATS_ENABLED'] = '0'
    # a node of a cluster: not a campaign's own Ray, whose switch a caller may pass on
    os.environ.pop('RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER', None)
    from ray._private import services
    from ray.scripts.scripts import main as ray_main

    services.resolve_ip_for_localhost = lambda host: host
    sys.argv = ['ray', 'start', *argv]
    return ray_main()


if __name__ == '__main__':
    sys.exit(main())
