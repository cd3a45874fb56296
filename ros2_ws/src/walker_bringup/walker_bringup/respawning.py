"""A graph's node processes kept up: a dead one started again, as launch's ``respawn``.

The decisions (restart or give up, and when) are :mod:`walker_bringup.core.respawn`'s; this
module applies them to a :class:`~walker_bringup.processes.ProcessGroup` and says what happened.
Each death is reported with the end of the node's log, each restart and each node given up on
with its reason, through ``say`` (the console of ``run_all.py``), and, through ``report``, as
the node's status on ``/diagnostics``, which the walk's bag records.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable

from walker_bringup.core.respawn import RespawnBook, RespawnPolicy
from walker_bringup.processes import ManagedProcess, ProcessGroup

__all__ = ['RespawningGroup', 'exit_text', 'rejoin_command', 'OK', 'WARN', 'ERROR']

#: Levels of a node's reported status (as ``diagnostic_msgs/DiagnosticStatus``'s)
OK, WARN, ERROR = 0, 1, 2

#: What a recorder started again is given: it continues its bag in a new file (the file the
#: killed one left cut completed first) instead of refusing a bag that exists.
_RECORDER_APPEND = ['-p', 'recorder.append:=true']
_COMPOSED_APPEND = '--append-bag'


def exit_text(code: int | None) -> str:
    """How a process ended, in words: ``exit code 1``, ``killed by SIGKILL``."""
    if code is None:
        return 'still running'
    if code < 0:
        try:
            return f'killed by {signal.Signals(-code).name}'
        except ValueError:
            return f'killed by signal {-code}'
    return f'exit code {code}'


def rejoin_command(process: ManagedProcess) -> list[str]:
    """Return the command line a dead node is started again with.

    Its own; a recorder's continues its bag (``recorder.append``), and so does a composed
    graph's that records (``--append-bag``). A composed graph's plant restores its snapshot
    as a plant process does (its ``--plant-state-file`` is in its command line already).
    """
    command = list(process.command or process.spec.command())
    if process.spec.executable == 'recorder_node' and command[-2:] != _RECORDER_APPEND:
        command += _RECORDER_APPEND
    if process.spec.executable == 'composed_graph' and '--record' in command \
            and _COMPOSED_APPEND not in command:
        command.append(_COMPOSED_APPEND)
    return command


class RespawningGroup:
    """Watch a process group, start its dead nodes again, give up on those that keep dying.

    Parameters
    ----------
    group : ProcessGroup
        The graph's processes (already started, or being started).
    policy : RespawnPolicy
        Delay and limit.
    say : callable
        ``say(line)`` prints a line on the console.
    label : str
        The walker's name for the lines ('' for a single walker).
    clock : callable
        Monotonic clock [s] (``time.monotonic``).
    report : callable, optional
        ``report(node, level, message)`` with the node's full name and a level of
        :data:`OK` (started again), :data:`WARN` (died, to be started again) or :data:`ERROR`
        (died and given up on).
    """

    def __init__(self, group: ProcessGroup, policy: RespawnPolicy,
                 say: Callable[[str], None], label: str = '',
                 clock: Callable[[], float] = time.monotonic,
                 report: Callable[[str, int, str], None] | None = None) -> None:
        self.group = group
        self.book = RespawnBook(policy)
        self._say = say
        self._prefix = f'{label}/' if label else ''
        self._clock = clock
        self._waiting: dict[str, ManagedProcess] = {}
        self._report = report or (lambda node, level, message: None)

    def poll(self) -> list[ManagedProcess]:
        """Answer the deaths since the last call and start the restarts due.

        Returns the dead processes of the nodes given up on (the graph is dead).
        """
        now = self._clock()
        given_up = []
        for process in self.group.poll_deaths():
            name = process.spec.name
            code = process.popen.returncode
            decision = self.book.on_death(name, code, now - process.started_at, now)
            record = self.book.record(name)
            if decision.respawn:
                self._waiting[name] = process
                self._report(process.spec.full_name, WARN,
                             f'died ({exit_text(code)}, death {record.deaths}); starting it '
                             f'again in {decision.restart_at - now:.1f} s')
                self._say(f'[walker] node {self._prefix}{name} died ({exit_text(code)}, death '
                          f'{record.deaths}); starting it again in '
                          f'{decision.restart_at - now:.1f} s. The end of its log:\n'
                          f'{process.log_tail(8)}')
            else:
                given_up.append(process)
                self._report(process.spec.full_name, ERROR,
                             f'died ({exit_text(code)}) and is not started again: '
                             f'{decision.gave_up}')
                self._say(f'[walker] node {self._prefix}{name} died ({exit_text(code)}) and is '
                          f'not started again: {decision.gave_up}')
        for name in self.book.due(now):
            dead = self._waiting.pop(name)
            process = self.group.restart(dead, rejoin_command(dead))
            self.book.on_restart(name)
            self._report(process.spec.full_name, OK,
                         f'started again (restart {self.book.record(name).restarts})')
            self._say(f'[walker] node {self._prefix}{name} started again (pid '
                      f'{process.popen.pid}, restart {self.book.record(name).restarts})')
        return given_up

    def summary(self) -> dict[str, dict]:
        """Return node -> deaths, restarts, exit codes and why it was given up.

        Every node that died has an entry: the walk summary's ``processes``.
        """
        return self.book.summary()
