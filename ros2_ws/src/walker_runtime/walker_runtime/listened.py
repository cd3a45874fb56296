"""Publishers of high-rate topics that build and send nothing while nobody subscribes.

A message through rclpy costs its Python construction, its conversion to C and Fast DDS's
publishing, even with no reader at all; in the composed sim-time graph the plant's
``joint_accelerations`` (500 Hz), its grippers' poses and the viz node's ``/tf`` often have
none (the controllers take the state by call; no RViz, no recorder). The topic stays
advertised with its type and QoS, so ``ros2 topic list``/``info`` show it unchanged, and the
moment a subscriber matches (``ros2 topic echo``, RViz, Foxglove, the recorder) the messages
flow again, within :data:`RECHECK_PERIOD` of its discovery.
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ['ListenedPublisher', 'RECHECK_PERIOD']

#: [s] steady time between two looks at a publisher's subscriber count (each is a call into
#: the middleware: not one a message)
RECHECK_PERIOD = 0.1


class ListenedPublisher:
    """An rclpy publisher whose :attr:`heard` says whether any subscriber matches it.

    Parameters
    ----------
    publisher : rclpy.publisher.Publisher
    steady_now : callable
        Steady time [s] (default :func:`time.monotonic`).
    recheck_period : float
        [s] how long a subscriber count is taken as current.
    """

    def __init__(self, publisher, steady_now: Callable[[], float] = time.monotonic,
                 recheck_period: float = RECHECK_PERIOD) -> None:
        self.publisher = publisher
        self._steady_now = steady_now
        self._recheck_period = recheck_period
        self._checked = -float('inf')
        self._heard = True

    @property
    def heard(self) -> bool:
        """Whether a subscriber matched at the last look (looked again when it is stale)."""
        now = self._steady_now()
        if now - self._checked >= self._recheck_period:
            self._checked = now
            self._heard = self.publisher.get_subscription_count() > 0
        return self._heard

    def publish(self, message) -> None:
        """Publish ``message`` when it is heard (build it only after asking :attr:`heard`)."""
        if self.heard:
            self.publisher.publish(message)
