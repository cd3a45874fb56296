"""The thin Ray layer: start or join a cluster, run the campaign's tasks, hand back their rows.

* **Local** (no address): a Ray instance of this process's own, on this machine's cores (or
  ``workers`` of them), with a temp directory of its own (removed at the end), without the
  dashboard, listening on 127.0.0.1 only: Ray 2.60 replaces a loopback node address by the
  machine's own on Linux unless clusters are switched off for the process
  (``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, which a single machine's Ray does not need), and
  its servers then listen on every interface. Its token authentication takes a token made
  for it (``RAY_AUTH_TOKEN``), so nothing is written to ``~/.ray``.
* **A cluster** (``address``): joins it as a driver. Its nodes are started from the walker
  environment (so that their workers can import the walker): on one machine with
  ``python -m walker_campaign.ray_node`` (loopback only), across machines with ``ray start``
  (see ``docs/campaigns.md``); the driver needs the cluster's token if it has one. A
  loopback address is kept as given (the same switch as a local Ray): Ray would otherwise
  look for the cluster at the machine's own address, where a loopback cluster is not.

Either way usage statistics stay off (``RAY_USAGE_STATS_ENABLED=0``, set before Ray is
imported). Each run is one task of one CPU running :func:`walker_campaign.execution.
execute_run`; Ray runs a task again elsewhere when its worker or node dies (``max_retries``),
and past that the runner submits it anew (``resubmissions``); a run whose every attempt died
is reported as lost, never written, and a resume runs it again. The driver keeps a window of
tasks in flight (twice the cluster's CPUs) so that the results stream in order of completion
and a cluster that grows is used.
"""

from __future__ import annotations

import collections
import os
import secrets
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable
from typing import Any

from walker_campaign.execution import RunTask, execute_run

__all__ = ['RayCampaign', 'LOOPBACK', 'ray_environment', 'is_loopback']

LOOPBACK = '127.0.0.1'
_POLL = 0.5  # [s] longest wait for a result before the driver looks again
_RESOURCE_PERIOD = 10.0  # [s] how often the window follows the cluster's size


def is_loopback(address: str) -> bool:
    """Whether a ``host:port`` address names this machine's loopback interface."""
    host = address.rsplit(':', 1)[0].strip('[]')
    return host == 'localhost' or host == '::1' or host.startswith('127.')


def ray_environment(address: str | None) -> None:
    """Set what Ray must see before it is imported, for a local Ray or one at ``address``.

    No usage statistics; for a local Ray, loopback only and a token of its own; for a
    cluster on loopback, loopback only.
    """
    os.environ['RAY_USAGE_STATS_ENABLED'] = '0'
    if address is None or is_loopback(address):
        os.environ['RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER'] = '0'
    if address is None:
        # one token for the process: Ray reads it once, and a second local Ray needs the same
        os.environ['RAY_AUTH_MODE'] = 'token'
        os.environ.setdefault('RAY_AUTH_TOKEN', secrets.token_hex(32))


def _execute_on_ray(task: RunTask, document: dict[str, Any]) -> list[dict[str, Any]]:
    """Run one walk as a task; its run row names the Ray node it ran on."""
    import ray

    rows = execute_run(task, document)
    rows[-1]['exec.node'] = ray.get_runtime_context().get_node_id()
    return rows


class RayCampaign:
    """A connection to Ray (started here or joined) for the duration of a campaign.

    Parameters
    ----------
    address : str, optional
        A running cluster's address (``host:port``, or ``auto``); ``None`` starts one here.
    workers : int, optional
        Local only: how many walks at once (default: every CPU of this machine).
    max_retries : int
        Times Ray runs a task again after its worker died.
    resubmissions : int
        Times the runner submits a run again after Ray gave up on it.
    """

    def __init__(self, address: str | None = None, workers: int | None = None,
                 max_retries: int = 3, resubmissions: int = 2) -> None:
        ray_environment(address)
        import ray

        self._ray = ray
        self._temp_dir = None
        if address is None:
            self._temp_dir = tempfile.mkdtemp(prefix='walker-ray-')
            try:
                ray.init(num_cpus=workers or os.cpu_count(), include_dashboard=False,
                         _node_ip_address=LOOPBACK, _temp_dir=self._temp_dir,
                         configure_logging=False, log_to_driver=False)
            except BaseException:
                shutil.rmtree(self._temp_dir, ignore_errors=True)
                raise
        else:
            if workers is not None:
                raise ValueError('workers is for a local Ray: a cluster has the CPUs its '
                                 'nodes were started with')
            ray.init(address=address, configure_logging=False, log_to_driver=False)
        self._remote = ray.remote(num_cpus=1, max_retries=max_retries,
                                  retry_exceptions=False)(_execute_on_ray)
        self.resubmissions = resubmissions

    @property
    def cpus(self) -> int:
        """CPUs of the cluster now."""
        return int(self._ray.cluster_resources().get('CPU', 0))

    def run(self, tasks: Iterable[RunTask], document: dict[str, Any],
            on_rows: Callable[[list[dict[str, Any]]], None]) -> dict[int, str]:
        """Run every task; call ``on_rows`` with each run's rows as it finishes.

        Returns
        -------
        dict
            Run index -> why it was lost, for runs whose every attempt died (none when the
            campaign is complete).
        """
        ray = self._ray
        queue = collections.deque(tasks)
        document_ref = ray.put(document)
        in_flight: dict[Any, RunTask] = {}
        submissions: collections.Counter[int] = collections.Counter()
        lost: dict[int, str] = {}
        window, sized_at = max(2, 2 * self.cpus), time.monotonic()
        while queue or in_flight:
            if time.monotonic() - sized_at > _RESOURCE_PERIOD:
                window, sized_at = max(2, 2 * self.cpus), time.monotonic()
            while queue and len(in_flight) < window:
                task = queue.popleft()
                submissions[task.plan.index] += 1
                in_flight[self._remote.remote(task, document_ref)] = task
            ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=_POLL)
            for ref in ready:
                task = in_flight.pop(ref)
                try:
                    rows = ray.get(ref)
                except ray.exceptions.RayError as error:
                    if submissions[task.plan.index] <= self.resubmissions:
                        queue.appendleft(task)
                    else:
                        lost[task.plan.index] = f'{type(error).__name__}: {error}'[:500]
                    continue
                on_rows(rows)
        return lost

    def close(self) -> None:
        """Disconnect (and stop a Ray started here, its temp directory removed)."""
        self._ray.shutdown()
        if self._temp_dir is not None:
            shutil.rmtree(self._temp_dir, ignore_errors=True)

    def __enter__(self) -> 'RayCampaign':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
