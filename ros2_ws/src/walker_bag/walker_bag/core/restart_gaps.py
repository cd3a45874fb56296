"""What a recorder started again did not record: each topic's span and about how many.

A recorder killed mid-walk and started again continues its bag in a new file
(``recorder.append``); what its topics published while no recorder ran is in no file, and no
middleware reports it lost (no subscription existed to lose it). :class:`RestartGaps` measures
it from the bag itself: the bag's end before the restart (the end of its last file, the newest
message the killed recorder wrote), each topic's first message after it, and the topic's rate
over the files before (messages over their span), which gives the estimate. The recorder writes
each gap into the bag as a ``diagnostic_msgs/DiagnosticStatus`` on ``/diagnostics`` and into its
``custom_data`` (:data:`GAP_KEY`), logs it, and the walk's summary reads it from there
(:func:`walker_bag.core.losses.recorded_losses`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from walker_bag.core.bag_metadata import FileInformation

__all__ = ['TopicGap', 'RestartGaps', 'GAP_KEY']

#: ``custom_data`` key of the restart's span; ``<GAP_KEY> <topic>`` holds each topic's gap.
GAP_KEY = 'recorder_gap'
_NS_PER_S = 1_000_000_000


@dataclasses.dataclass(frozen=True)
class TopicGap:
    """One topic's messages not recorded across a restart.

    Attributes
    ----------
    topic : str
    start_ns, end_ns : int
        The bag's end before the restart and the topic's first message after it [ns, log time].
    estimated : int
        Messages published in between, at the topic's rate before (0 when it had none).
    """

    topic: str
    start_ns: int
    end_ns: int
    estimated: int

    @property
    def span(self) -> float:
        """Length of the gap [s]."""
        return (self.end_ns - self.start_ns) / _NS_PER_S

    def text(self) -> str:
        """One line: topic, span and estimated count."""
        return (f'{self.topic}: not recorded for {self.span:.2f} s '
                f'({self.start_ns / _NS_PER_S:.3f} s to {self.end_ns / _NS_PER_S:.3f} s, '
                f'about {self.estimated} messages) while the recorder was down')

    def value(self) -> str:
        """Return the ``custom_data`` value: ``start_ns end_ns estimated``."""
        return f'{self.start_ns} {self.end_ns} {self.estimated}'


class RestartGaps:
    """The gap of each topic after a restart, found at its first message.

    Parameters
    ----------
    end_ns : int
        The bag's end before the restart [ns, log time].
    rates : mapping of str to float
        Each topic's rate before the restart [messages/s].
    """

    def __init__(self, end_ns: int, rates: Mapping[str, float],
                 earlier: Mapping[str, str] | None = None) -> None:
        self.end_ns = int(end_ns)
        self._rates = dict(rates)
        self._heard: set[str] = set()
        self.gaps: list[TopicGap] = []
        #: the gap entries of earlier restarts (``custom_data``), kept before this one's
        self._earlier = {k: v for k, v in (earlier or {}).items()
                         if k == GAP_KEY or k.startswith(GAP_KEY + ' ')}

    @classmethod
    def after(cls, files: Sequence[tuple[FileInformation, Mapping[str, int]]],
              earlier: Mapping[str, str] | None = None) -> 'RestartGaps | None':
        """Gaps after the files a bag continued from (None when there are none).

        ``files``: each earlier file's information and its message count per topic;
        ``earlier``: the bag's ``custom_data``, whose gaps of earlier restarts are kept.
        """
        files = [(info, counts) for info, counts in files if info.message_count > 0]
        if not files:
            return None
        end = max(info.starting_time_ns + info.duration_ns for info, _ in files)
        span = sum(info.duration_ns for info, _ in files) / _NS_PER_S
        totals: dict[str, int] = {}
        for _, counts in files:
            for topic, count in counts.items():
                totals[topic] = totals.get(topic, 0) + int(count)
        rates = {topic: count / span for topic, count in totals.items()} if span > 0 else {}
        return cls(end, rates, earlier)

    def first_message(self, topic: str, log_time_ns: int) -> TopicGap | None:
        """Note a message received after the restart; return its topic's gap at the first.

        None for a topic already heard, one not recorded before the restart (no rate to
        estimate from: a topic new to the bag) or a message not after the bag's end.
        """
        if topic in self._heard:
            return None
        self._heard.add(topic)
        rate = self._rates.get(topic)
        if rate is None or log_time_ns <= self.end_ns:
            return None
        gap = TopicGap(topic, self.end_ns, int(log_time_ns),
                       int(round(rate * (log_time_ns - self.end_ns) / _NS_PER_S)))
        self.gaps.append(gap)
        return gap

    def custom_data(self) -> dict[str, str]:
        """Return the bag's ``custom_data`` gap entries, earlier restarts' first.

        ``recorder_gap``: ``start_ns end_ns estimated`` of each restart, and
        ``recorder_gap <topic>`` of each topic's gaps, ``;`` between restarts.
        """
        entries = dict(self._earlier)
        if not self.gaps:
            return entries
        restart = (f'{self.end_ns} {max(g.end_ns for g in self.gaps)} '
                   f'{sum(g.estimated for g in self.gaps)}')
        for key, value in [(GAP_KEY, restart),
                           *((f'{GAP_KEY} {g.topic}', g.value()) for g in self.gaps)]:
            entries[key] = f'{entries[key]};{value}' if key in entries else value
        return entries
