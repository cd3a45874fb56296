"""Health of the graph as the supervisor sees it: who is alive, who reports trouble.

Each source (the plant's joint states, its gripper heartbeat, each joint controller's state)
is expected at least every ``timeout`` seconds of the *steady* clock: a dead or frozen publisher
is noticed even when the simulation clock has stopped with it. A controller that reports its
inputs stale (it is holding because its setpoint or state stream stopped) is a fault while the
walker is moving. The monitor only keeps time and counts; the sequencer decides what a fault
means for the step.
"""

from __future__ import annotations

import dataclasses
import enum

__all__ = ['Level', 'SourceStatus', 'HealthMonitor', 'reason_naming_silent_sources',
           'controller_trouble', 'tell_mode_again', 'ModeRepetition']


class Level(enum.IntEnum):
    """Severity, as ``diagnostic_msgs/DiagnosticStatus`` levels."""

    OK = 0
    WARN = 1
    ERROR = 2


@dataclasses.dataclass(frozen=True)
class SourceStatus:
    """One monitored source now."""

    name: str
    level: Level
    message: str


class HealthMonitor:
    """Freshness and reported trouble of named sources.

    Parameters
    ----------
    sources : dict of str to float
        Source name -> timeout [s] (steady clock) after which silence is a fault.
    trouble_grace : float
        [s] how long a source must report trouble without a break before :meth:`faults`
        counts it: a report sent just before a command that clears it (a controller still
        holding when a step starts) is not a fault.
    """

    def __init__(self, sources: dict[str, float], trouble_grace: float = 0.0) -> None:
        for name, timeout in sources.items():
            if not timeout > 0:
                raise ValueError(f'timeout of {name!r} must be positive, got {timeout}')
        if not trouble_grace >= 0:
            raise ValueError(f'trouble_grace must be zero or positive, got {trouble_grace}')
        self._timeouts = dict(sources)
        self._grace = float(trouble_grace)
        self._last_seen: dict[str, float] = {}
        self._trouble: dict[str, str] = {}
        self._trouble_since: dict[str, float] = {}

    def set_timeouts(self, timeout: float, trouble_grace: float) -> None:
        """Give every source the timeout ``timeout`` [s] and the trouble grace [s] anew.

        What has been heard is kept. Raises ValueError, changing nothing, on a bad value.
        """
        if not timeout > 0:
            raise ValueError(f'timeout must be positive, got {timeout}')
        if not trouble_grace >= 0:
            raise ValueError(f'trouble_grace must be zero or positive, got {trouble_grace}')
        self._timeouts = dict.fromkeys(self._timeouts, float(timeout))
        self._grace = float(trouble_grace)

    @property
    def names(self) -> list[str]:
        """The monitored sources."""
        return list(self._timeouts)

    def seen(self, name: str, now: float, trouble: str = '') -> None:
        """Record that ``name`` was heard from at steady time ``now`` [s].

        ``trouble`` is what the source itself reports as wrong ('' when nothing).
        """
        if name not in self._timeouts:
            raise KeyError(f'unknown source {name!r}')
        self._last_seen[name] = now
        self._trouble[name] = trouble
        if not trouble:
            self._trouble_since.pop(name, None)
        else:
            self._trouble_since.setdefault(name, now)

    def excuse(self, names, now: float) -> None:
        """Count sources as heard at steady time ``now`` [s] without a word from them.

        For a silence known to have a cause other than the source's death (in sim time, the
        supervisor holding the clock: the plant steps no further, and nothing driven by its
        states speaks), so that it is no fault, and the source has a whole timeout to be heard
        again once the cause is gone. What a source reported as trouble is kept; a source never
        heard from stays unheard.
        """
        for name in names:
            if name not in self._timeouts:
                raise KeyError(f'unknown source {name!r}')
            if name in self._last_seen:
                self._last_seen[name] = max(self._last_seen[name], now)

    def last_heard(self, name: str) -> float | None:
        """Steady time [s] ``name`` was last heard from; None if never."""
        if name not in self._timeouts:
            raise KeyError(f'unknown source {name!r}')
        return self._last_seen.get(name)

    def unheard(self) -> list[str]:
        """Return the sources not heard from yet."""
        return [name for name in self._timeouts if name not in self._last_seen]

    def status(self, now: float) -> list[SourceStatus]:
        """Every source's status at steady time ``now`` [s]."""
        statuses = []
        for name, timeout in self._timeouts.items():
            last = self._last_seen.get(name)
            if last is None:
                statuses.append(SourceStatus(name, Level.ERROR, 'not heard from yet'))
            elif now - last > timeout:
                statuses.append(SourceStatus(
                    name, Level.ERROR, f'silent for {now - last:.2f} s (timeout {timeout:g} s)'))
            elif self._trouble.get(name):
                statuses.append(SourceStatus(name, Level.WARN, self._trouble[name]))
            else:
                statuses.append(SourceStatus(name, Level.OK, 'alive'))
        return statuses

    def faults(self, now: float, include_trouble: bool) -> list[str]:
        """Faults now, one sentence each: silent sources and, if asked, lasting trouble.

        Trouble counts once it has been reported without a break for ``trouble_grace``.
        """
        return [f'{s.name}: {s.message}' for s in self.status(now)
                if s.level == Level.ERROR
                or (include_trouble and s.level == Level.WARN
                    and now - self._trouble_since.get(s.name, now) >= self._grace)]


def reason_naming_silent_sources(reason: str, statuses: list[SourceStatus]) -> str:
    """Return the reason of a safe hold with every silent source it does not name yet added.

    A dead node is often noticed first through what it stops: the controllers hold on inputs
    gone stale, within timeouts shorter than the watchdog's, and the walker stops with their
    complaint as its reason. Once the watchdog sees the dead source itself, the reason should
    name it too. Returns ``reason`` unchanged when it names every silent source already.
    """
    new = [f'{s.name}: {s.message}' for s in statuses
           if s.level == Level.ERROR and s.message != 'not heard from yet'
           and s.name not in reason]
    if not new:
        return reason
    return f'{reason}; then {"; ".join(new)}' if reason else '; '.join(new)


#: [s] A controller report stamped less than this after a mode command may have been made
#: before the command reached the controller (DDS latency, a starved process).
MODE_COMMAND_LATENCY = 0.1


def tracking_expected(step_busy: bool, commanded_mode: str, report_stamp: float,
                      commanded_at: float) -> bool:
    """Return True if a controller's report should show it tracking the step's motion.

    Parameters
    ----------
    step_busy : bool
        A step is under way.
    commanded_mode : str
        The supervisor's last mode command ('hold', 'coarse', 'fine', ...).
    report_stamp, commanded_at : float
        Stamp of the report and time of the mode command [s], on the same (ROS) clock. A report
        stamped within :data:`MODE_COMMAND_LATENCY` of the command may still show the mode
        before it (a HOLD while the gripper unscrewed, say): it says nothing about a fall-back.
    """
    return (step_busy and commanded_mode in ('coarse', 'fine')
            and report_stamp - commanded_at >= MODE_COMMAND_LATENCY)


def controller_trouble(stale: bool, holding: bool, tracking_commanded: bool) -> str:
    """Return what is wrong with a joint controller by its own report ('' when nothing).

    Parameters
    ----------
    stale : bool
        It reports an input stream timed out (it is holding for that).
    holding : bool
        It reports the HOLD mode.
    tracking_commanded : bool
        A step is under way and the supervisor's last mode command was COARSE or FINE.

    A controller whose inputs went stale holds, and keeps holding once they are fresh again
    until the next mode command (its reference has moved on meanwhile: tracking it again at once
    would jump). Its stale flag is then down, but it no longer follows the step's motion: the
    arm stops wherever it was, mid-sweep perhaps, while the step goes on without it.
    """
    if stale:
        return 'holding: its inputs are stale'
    if holding and tracking_commanded:
        return 'holding since its inputs went stale: it follows no motion until a mode command'
    return ''


def tell_mode_again(stale: bool, holding: bool, tracking_commanded: bool) -> bool:
    """Return True when a controller should be sent the step's mode again.

    It fell back to HOLD when an input stalled for a moment (a loaded machine delays a stream
    by more than its timeout), its inputs are fresh again, and the step expects it to track: the
    mode command lets it follow the motion again, with bumpless transfer, instead of leaving the
    arm stopped mid-motion. A controller whose inputs stay stale is not told: it holds, and the
    trouble becomes a fault after the watchdog's grace.
    """
    return holding and tracking_commanded and not stale


class ModeRepetition:
    """Counts the mode commands repeated in vain; says when to make the publisher anew.

    A controller told its mode again (:func:`tell_mode_again`) that still reports HOLD after
    several repetitions is not hearing ``control_mode``: seen with Fast DDS's shared-memory
    transport after a process of the graph was killed and started again. A new publisher is
    matched anew with every controller; those that did hear get the same mode once more, which
    changes nothing for them.

    Parameters
    ----------
    renew_after : int
        Repetitions in a row, with some controller still holding, before the publisher is
        made anew (>= 1).
    """

    def __init__(self, renew_after: int = 4) -> None:
        if renew_after < 1:
            raise ValueError(f'renew_after must be at least 1, got {renew_after!r}')
        self.renew_after = int(renew_after)
        self.repeated = 0
        self.renewals = 0

    def heard(self) -> None:
        """No controller needs the mode again: the count starts over."""
        self.repeated = 0

    def repeat(self) -> bool:
        """Note one more repetition; return True when the publisher should be made anew."""
        self.repeated += 1
        if self.repeated < self.renew_after:
            return False
        self.repeated = 0
        self.renewals += 1
        return True
