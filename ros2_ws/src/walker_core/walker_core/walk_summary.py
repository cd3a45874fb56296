"""How a walk went: the one summary every way of running a walk returns (ROS-free).

The walk session's backends (:mod:`walker_bringup.session`: the ROS graph and the headless
runner) and the headless runner's library call (:func:`walker_headless.runner.walk`) all return
a :class:`WalkSummary`; ``summary.json`` holds its fields. It lives in the core because the
headless runner and the bring-up both build it and neither imports the other's way back.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Any

__all__ = ['WalkSummary', 'Runner']


class Runner(enum.StrEnum):
    """What ran the walk (:attr:`WalkSummary.runner`, ``summary.json``'s ``runner``)."""

    GRAPH = 'graph'  # the ROS graph, any arrangement
    HEADLESS = 'headless'  # the cores in one lock-step loop, no ROS


@dataclasses.dataclass(frozen=True)
class WalkSummary:
    """How a walk went, from any runner (``summary.json``'s fields, and the runner's own).

    Attributes
    ----------
    target : str
        The node walked to.
    reached : bool
        Every planned step succeeded.
    message : str
        Why not ('' when reached).
    path : tuple of str
        The nodes the moving grippers were screwed into, in order.
    steps_taken : int
        Steps that succeeded.
    duration : float
        Time of the steps that succeeded [s], summed.
    rows : tuple of StepRow
        The per-step table (:func:`walker_report.core.steps.rows_from_reports`; empty until
        a session makes it from ``reports``).
    wall_time : float
        Wall time of the walk [s], set-up included (not part of its outcome).
    runner : str
        ``'graph'`` or ``'headless'`` (:class:`Runner`).
    loop : dict, optional
        The control loop's record (``summary.json``'s ``loop``).
    processes : dict
        Deaths and restarts of each node that died (the graph's; empty headless).
    timed_out : bool
        Stopped at the wall-time limit, unreached.
    namespace : str
        The walker's namespace.
    reports : tuple of StepReportRecord
        The headless runner's step reports, one per step ended (the graph's are ``rows``).
    phases : tuple of PhaseRecord
        The headless runner's phase messages, in order.
    sim_time : float
        Simulated time at the end [s] (headless).
    periods : int
        Control periods simulated (headless).
    cpu_time : float
        CPU time of the headless loop, from the walk's start to its end [s], the wrist
        cameras' renders (in a process of their own) included (not part of the walk's
        outcome): ``sim_time / cpu_time`` is the loop's speed on one core.
    survey : dict, optional
        The truss map at the end (headless;
        :meth:`~walker_supervisor.core.truss_map.TrussMap.to_dict`).
    grip_states, grip_losses : int
        The grip monitor (headless): the plant's gripper-state messages, and those with no
        gripper attached (a grip loss: the walker let go of the truss).
    looks : tuple of dict
        The wrist camera's looks against the plant's truth (headless;
        :func:`walker_headless.shell.look_record`).
    """

    target: str
    reached: bool
    message: str
    path: tuple[str, ...]
    steps_taken: int
    duration: float
    rows: tuple[Any, ...] = ()
    wall_time: float = 0.0
    runner: str = Runner.GRAPH
    loop: dict | None = None
    processes: dict = dataclasses.field(default_factory=dict)
    timed_out: bool = False
    namespace: str = '/walker'
    reports: tuple[Any, ...] = ()
    phases: tuple[Any, ...] = ()
    sim_time: float = 0.0
    periods: int = 0
    cpu_time: float = 0.0
    survey: dict | None = None
    grip_states: int = 0
    grip_losses: int = 0
    looks: tuple[dict, ...] = ()

    @property
    def code(self) -> int:
        """run_all.py's exit code of the walk: 0 reached, 1 not."""
        return 0 if self.reached else 1

    def json_fields(self, *names: str) -> dict[str, Any]:
        """Return the named fields as ``summary.json`` writes them (a tuple as a list).

        Raises
        ------
        AttributeError
            If a name is no field of the summary.
        """
        known = {field.name for field in dataclasses.fields(self)}
        unknown = [name for name in names if name not in known]
        if unknown:
            raise AttributeError(f'no field {", ".join(unknown)} in a walk summary')
        values = {name: getattr(self, name) for name in names}
        return {name: list(value) if isinstance(value, tuple) else value
                for name, value in values.items()}
