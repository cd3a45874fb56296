"""Messages the middleware reported lost on the way to the recorder, per topic.

A recorder that stalls (frozen, starved of the processor) while its publishers go on loses what
they could not hold for it: a best-effort message is gone once it is overwritten in the
recorder's own queue or dropped on the way; a reliable one once the publisher's history (its
QoS depth) has moved past it. The middleware reports each loss to the subscription (rclpy's
``message_lost`` event, Fast DDS's *sample lost* status: a gap in the publisher's sequence
numbers, or a gap the publisher announces for samples it no longer holds). The recorder counts
them here, and says so in its log, on ``/diagnostics`` and in the bag's ``custom_data``, so a
bag with a hole says where and how big it is.
"""

from __future__ import annotations

import dataclasses

from walker_bag.core.restart_gaps import GAP_KEY

__all__ = ['TopicLoss', 'LossLedger', 'LOST_KEY', 'recorded_losses', 'loss_lines']

#: ``custom_data`` key of the total lost; ``<LOST_KEY> <topic>`` holds each topic's count.
LOST_KEY = 'messages_lost'


@dataclasses.dataclass
class TopicLoss:
    """What was lost on one topic: how many, and the log times [ns] of the first and last."""

    reliable: bool
    count: int = 0
    first_ns: int = 0
    last_ns: int = 0


class LossLedger:
    """The count of lost messages of every recorded topic."""

    def __init__(self) -> None:
        self._topics: dict[str, TopicLoss] = {}

    @property
    def total(self) -> int:
        """Messages lost on every topic."""
        return sum(loss.count for loss in self._topics.values())

    @property
    def topics(self) -> dict[str, TopicLoss]:
        """Each topic with losses (a copy)."""
        return dict(self._topics)

    def lost(self, topic: str, count: int, reliable: bool, now_ns: int) -> str:
        """Count ``count`` more messages lost on ``topic``; return the line to log ('' for 0).

        ``reliable`` says how the recorder subscribes to it; ``now_ns`` is the recorder's
        clock (the bag's log time) when the loss was reported.
        """
        if count <= 0:
            return ''
        loss = self._topics.setdefault(topic, TopicLoss(reliable, first_ns=now_ns))
        loss.count += count
        loss.last_ns = now_ns
        why = ("overwritten in the publisher's history before it reached the recorder"
               if reliable else 'best effort, dropped before the recorder took it')
        return (f'{topic}: {count} message{"s" if count != 1 else ""} lost ({why}); '
                f'{loss.count} in all on this topic, {self.total} on every topic')

    def summary(self) -> str:
        """One line: every topic with its losses, or that nothing was lost."""
        if not self._topics:
            return 'no message lost'
        return f'{self.total} messages lost: ' + ', '.join(
            f'{topic} {loss.count} ({"reliable" if loss.reliable else "best effort"})'
            for topic, loss in sorted(self._topics.items()))

    def custom_data(self) -> dict[str, str]:
        """Return the bag's ``custom_data`` entries: the total, and each topic's count."""
        entries = {LOST_KEY: str(self.total)}
        entries.update({f'{LOST_KEY} {topic}': str(loss.count)
                        for topic, loss in sorted(self._topics.items())})
        return entries


def recorded_losses(custom_data: dict[str, str]) -> dict:
    """Return what a bag says it lacks, from its ``custom_data``: plain data for a summary.

    Returns ``{'messages_lost': total, 'lost': {topic: count}, 'not_recorded': [{'topic',
    'start', 'end', 'span' [s], 'estimated'}]}``: the messages the middleware reported lost
    (a recorder that stalled) and the spans a recorder started again did not record
    (:mod:`walker_bag.core.restart_gaps`). Malformed entries are left out.
    """
    lost = {}
    for key, value in custom_data.items():
        if key.startswith(LOST_KEY + ' '):
            try:
                lost[key[len(LOST_KEY) + 1:]] = int(value)
            except ValueError:
                continue
    gaps = []
    for key, value in sorted(custom_data.items()):
        if not key.startswith(GAP_KEY + ' '):
            continue
        for entry in value.split(';'):
            try:
                start, end, estimated = (int(v) for v in entry.split())
            except ValueError:
                continue
            gaps.append({'topic': key[len(GAP_KEY) + 1:], 'start': start * 1e-9,
                         'end': end * 1e-9, 'span': (end - start) * 1e-9,
                         'estimated': estimated})
    return {'messages_lost': sum(lost.values()), 'lost': lost, 'not_recorded': gaps}


def loss_lines(losses: dict) -> list[str]:
    """Lines for a console or a report of :func:`recorded_losses` (none when nothing lacks)."""
    lines = []
    if losses['messages_lost']:
        lines.append(f'{losses["messages_lost"]} messages lost on the way to the recorder: '
                     + ', '.join(f'{topic} {count}'
                                 for topic, count in sorted(losses['lost'].items())))
    if losses['not_recorded']:
        total = sum(gap['estimated'] for gap in losses['not_recorded'])
        worst = max(gap['span'] for gap in losses['not_recorded'])
        lines.append(f'about {total} messages not recorded while the recorder was down (up to '
                     f'{worst:.2f} s): ' + ', '.join(
                         f'{gap["topic"]} ~{gap["estimated"]} ({gap["span"]:.2f} s from '
                         f'{gap["start"]:.2f} s)' for gap in losses['not_recorded']))
    return lines
