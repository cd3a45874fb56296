"""The graph's node deaths the bring-up reports, named in the hold it then asks for (no ROS).

``run_all.py`` starts a dead node again; one that keeps dying is given up on, and the bring-up
asks the supervisor to hold over the ``hold`` service (``std_srvs/Trigger``, which carries no
reason). Before it asks, it reports the death as the node's status on ``/diagnostics``
(``<node> (process)``, ERROR). A hold asked for shortly after such a report names the dead node,
not an operator, so that the phase history and the bag say why the walker holds.
"""

from __future__ import annotations

__all__ = ['ProcessDeaths', 'PROCESS_STATUS_SUFFIX', 'OPERATOR_HOLD']

#: The suffix of the bring-up's status of a node process on ``/diagnostics``
PROCESS_STATUS_SUFFIX = ' (process)'
#: The reason of a hold asked for over the ``hold`` service with no death reported before it
OPERATOR_HOLD = 'hold requested by an operator'
#: [s] steady time a reported death explains a hold asked for after it
_MEMORY = 10.0


class ProcessDeaths:
    """The node deaths reported within the robot's namespace, the newest kept.

    Parameters
    ----------
    namespace : str
        The robot's namespace (``/walker``): deaths of other robots' nodes are not this one's.
    """

    def __init__(self, namespace: str) -> None:
        self._prefix = namespace.rstrip('/') + '/'
        self._newest: tuple[float, str] | None = None  # (steady time [s], what happened)

    def status(self, name: str, level: int, message: str, steady: float) -> None:
        """Take a ``/diagnostics`` status: a node process given up on (ERROR, level 2) counts."""
        if level >= 2 and name.endswith(PROCESS_STATUS_SUFFIX) and name.startswith(self._prefix):
            self._newest = (steady, f'node {name.removesuffix(PROCESS_STATUS_SUFFIX)} {message}')

    def hold_reason(self, steady: float) -> str:
        """Return the reason of a hold asked for now over the ``hold`` service."""
        if self._newest is not None and 0.0 <= steady - self._newest[0] <= _MEMORY:
            return f'hold requested by the bring-up: {self._newest[1]}'
        return OPERATOR_HOLD
