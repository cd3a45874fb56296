"""Run the plant (or the composed graph) with timing probes in the plant; dump them on exit.

Usage (what the benchmarks start in place of the plant's executable)::

    python benchmarks/loop_probe.py plant <the plant's --ros-args ...>
    python benchmarks/loop_probe.py composed <composed_graph options ...>

The file named by the environment variable ``WALKER_LOOP_EVENTS`` receives, when the process
ends (SIGINT), numpy arrays (``.npz``) of what the plant saw:

* ``tick``: start of each real-time timer tick [ns, monotonic];
* ``publish_stamp``, ``publish_time``: each state the plant published (its stamp [ns], the
  time it started publishing [ns, monotonic]);
* ``effort_stamp``, ``effort_time``, ``effort_count``: each effort command reaching the
  plant's callback (the stamp of the state it answers, arrival time, number of joints in it);
* ``plant_missed``, ``overruns``, ``lockstep_timeouts``: the plant's own counters at each
  publish.

The probes wrap three methods of ``walker_sim.plant_node.PlantNode`` at class level before any
node is built, so the plant is the real one, started through its real ``main()`` (or built by
the composed graph), and no observer process adds load: an append per event is all they cost.
"""

from __future__ import annotations

import array
import os
import sys
import time


def _install(events: dict[str, array.array]) -> None:
    from walker_sim import plant_node

    node_class = plant_node.PlantNode
    tick, publish, on_effort = node_class._tick, node_class._publish, node_class._on_effort
    now = time.monotonic_ns

    def timed_tick(self):
        events['tick'].append(now())
        tick(self)

    def timed_publish(self, state):
        events['publish_stamp'].append(self._stamp)
        events['publish_time'].append(now())
        events['plant_missed'].append(sum(self.lockstep.missed.values()))
        events['overruns'].append(self._counts['overruns'])
        events['lockstep_timeouts'].append(self.lockstep.timeouts)
        publish(self, state)

    def timed_effort(self, message):
        events['effort_time'].append(now())
        stamp = message.header.stamp
        events['effort_stamp'].append(stamp.sec * 1_000_000_000 + stamp.nanosec)
        events['effort_count'].append(len(message.name))
        on_effort(self, message)

    node_class._tick = timed_tick
    node_class._publish = timed_publish
    node_class._on_effort = timed_effort


def _dump(events: dict[str, array.array], path: str) -> None:
    import numpy as np

    np.savez(path, **{name: np.frombuffer(values, dtype=np.int64) if len(values) else
                      np.zeros(0, dtype=np.int64) for name, values in events.items()})


def main(argv: list[str]) -> int:
    """Run the probed plant or composed graph; return its exit code."""
    if len(argv) < 1 or argv[0] not in ('plant', 'composed'):
        print('usage: loop_probe.py plant|composed ARGS...', file=sys.stderr)
        return 2
    path = os.environ.get('WALKER_LOOP_EVENTS')
    if not path:
        print('loop_probe.py: set WALKER_LOOP_EVENTS to the output file', file=sys.stderr)
        return 2
    names = ('tick', 'publish_stamp', 'publish_time', 'plant_missed', 'overruns',
             'lockstep_timeouts', 'effort_stamp', 'effort_time', 'effort_count')
    events = {name: array.array('q') for name in names}
    _install(events)
    try:
        if argv[0] == 'plant':
            from walker_sim import plant_node

            sys.argv = ['plant_node', *argv[1:]]
            return plant_node.main() or 0
        from walker_bringup import composed_process

        sys.argv = ['composed_graph', *argv[1:]]
        return composed_process.main() or 0
    finally:
        _dump(events, path)


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
