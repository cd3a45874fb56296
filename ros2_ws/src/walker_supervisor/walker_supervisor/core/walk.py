"""A walk: the route to a target node taken step by step, with its figures."""

from __future__ import annotations

import collections
import dataclasses
import math

import numpy as np

from walker_supervisor.core.route import PlannedStep, Stance
from walker_supervisor.core.phases import StepOutcome

__all__ = ['Walk', 'VibrationMeter']


@dataclasses.dataclass
class Walk:
    """Progress of a walk along a planned route.

    Attributes
    ----------
    target : str
        Node to reach.
    route : list of PlannedStep
        Steps planned when the walk started.
    outcomes : list of StepOutcome
        One per step taken so far.
    cancel_requested : bool
        Set when the walk is cancelled: the step under way finishes (the walker ends with both
        grippers attached) and no other starts.
    """

    target: str
    route: list[PlannedStep]
    outcomes: list[StepOutcome] = dataclasses.field(default_factory=list)
    cancel_requested: bool = False

    @property
    def step_index(self) -> int:
        """Index of the step under way, or of the next one."""
        return len(self.outcomes)

    @property
    def failed(self) -> bool:
        """True once a step has failed."""
        return any(not o.success for o in self.outcomes)

    @property
    def finished(self) -> bool:
        """True when every step is done, a step failed, or a cancel took effect."""
        return self.failed or self.step_index >= len(self.route) or self.cancel_requested

    @property
    def reached(self) -> bool:
        """True when every planned step succeeded."""
        return self.step_index == len(self.route) and not self.failed

    def refusal(self, step_running: bool) -> str:
        """Why another walk or step cannot start while this walk's goal is open.

        A walk that has taken its last step (``step_running`` False) ends only once the joints
        have relaxed under the new base (``supervisor.relaxation_wait`` after the screw-in),
        while the phase already reads IDLE: a goal sent then is told to come again, not to
        cancel.
        """
        if self.finished and not step_running:
            return (f'the walk to {self.target} is ending: the joints relax under the new base '
                    f'after its last screw-in (supervisor.relaxation_wait); send the goal '
                    f'again in a moment')
        return f'a walk to {self.target} is running: cancel it first'

    def next_step(self) -> PlannedStep:
        """Return the step to take now; raises IndexError when the walk is finished."""
        if self.finished:
            raise IndexError('the walk is finished')
        return self.route[self.step_index]

    def stance(self, initial: Stance) -> Stance:
        """Stance after the steps taken so far, from the walk's initial stance."""
        done = [s for s, o in zip(self.route, self.outcomes, strict=False) if o.success]
        return done[-1].stance_after() if done else initial

    @property
    def path(self) -> list[str]:
        """Nodes the moving grippers were inserted into, in order."""
        return [s.to_node for s, o in zip(self.route, self.outcomes, strict=False)
                if o.success]


class VibrationMeter:
    """Residual tip vibration: the largest deviation from the mean over a recent window.

    Parameters
    ----------
    window : float
        Length of the window [s].
    """

    def __init__(self, window: float) -> None:
        if not window > 0:
            raise ValueError(f'the vibration window must be positive, got {window} s')
        self.window = window
        self._times: collections.deque[float] = collections.deque()
        self._points: collections.deque[np.ndarray] = collections.deque()

    def add(self, time: float, point: np.ndarray) -> None:
        """Add a tip position [m] measured at ``time`` [s]; old samples fall out."""
        self._times.append(time)
        self._points.append(np.asarray(point, dtype=float))
        while self._times and self._times[0] < time - self.window:
            self._times.popleft()
            self._points.popleft()

    def clear(self) -> None:
        """Forget every sample."""
        self._times.clear()
        self._points.clear()

    def amplitude(self) -> float:
        """Largest distance [m] of a sample from the window's mean; NaN when empty."""
        if not self._points:
            return math.nan
        points = np.array(self._points)
        return float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=1)))

    def mean(self) -> np.ndarray:
        """Mean tip position [m] over the window."""
        return np.array(self._points).mean(axis=0) if self._points else np.full(3, math.nan)

    def latest(self) -> np.ndarray:
        """Return the newest tip position [m]; NaN when empty."""
        return self._points[-1].copy() if self._points else np.full(3, math.nan)
