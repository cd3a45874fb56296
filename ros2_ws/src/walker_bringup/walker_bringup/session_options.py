"""What a walk session runs and how: its options, and the summary every backend returns.

:class:`SessionOptions` is the small frozen set a :class:`~walker_bringup.session.WalkSession`
is built with besides the walker's configuration: the arrangement (the graph as processes,
with the controllers grouped, with the loop or the whole graph composed, or the headless
runner), sim or real time, recording, the output directory, the respawn policy, and the
graph's own settings. :class:`~walker_core.walk_summary.WalkSummary` (re-exported here) is
what a walk returns, from the graph or the headless runner alike (``summary.json`` holds its
fields).
"""

from __future__ import annotations

import dataclasses
import enum
from pathlib import Path
from walker_core.walk_summary import WalkSummary

from walker_bringup.core.respawn import RespawnPolicy
from walker_bringup.graph import NodeSpec

__all__ = ['Arrangement', 'SessionOptions', 'WalkSummary', 'SessionError', 'NO_SPLIT']

#: The recorder's bag split (bytes, seconds, files kept) that never splits.
NO_SPLIT = (0, 0.0, 0)


class Arrangement(enum.StrEnum):
    """How the walker runs: a ROS graph in one of four arrangements, or the headless runner."""

    PROCESSES = 'processes'  # one process per node
    GROUPED = 'grouped'  # one process per node, the five joint controllers as one node
    COMPOSED_LOOP = 'composed_loop'  # the loop (plant, controllers) in one process
    COMPOSED = 'composed'  # each graph in one process
    HEADLESS = 'headless'  # no ROS: the cores in one lock-step loop in this process

    @property
    def graph(self) -> bool:
        """Return True for a ROS graph, False for the headless runner."""
        return self is not Arrangement.HEADLESS


class SessionError(RuntimeError):
    """A session that cannot do what it was asked; ``code`` is run_all.py's exit code for it.

    2: options, parameter file or target refused (nothing started); 3: the graph did not come
    up; 5: a node was given up on; 130: interrupted (Ctrl-C).
    """

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code


@dataclasses.dataclass(frozen=True)
class SessionOptions:
    """How a session runs the walker (every field has run_all.py's default).

    Attributes
    ----------
    arrangement : Arrangement
        The graph's arrangement, or the headless runner.
    sim_time : bool
        Run on the plant's clock, lock-stepped (the headless runner always does).
    record : bool
        Record a rosbag2 bag of the walk (``<out>/bag``).
    report : bool
        Make the walk report from the bag (``<out>/report``) after the walk.
    out : Path, optional
        Output directory (``None``: ``runs/<date-time>``).
    namespace : str
        The robot's namespace (with several walkers, named by the session itself).
    respawn : RespawnPolicy
        When a dead node process is started again, and when the graph is given up.
    startup_timeout, walk_timeout : float
        Wall-clock seconds the graph may take to come up, and a walk to end.
    quiet : bool
        Print only the summary (and errors).
    plant_params_file : Path, optional
        The plant's own parameter file (a campaign's truth).
    transport : str, optional
        ``udp`` or ``shm`` (``None``: the default of :mod:`walker_bringup.transport`).
    realtime : int
        SCHED_FIFO priority of the loop on the wall clock (0: none).
    foxglove_port : int, optional
        Serve the graph's topics to Foxglove on this port (``None``: no server).
    bag_split : tuple of (int, float, int)
        The recorder's split: bytes per file, seconds per file, files kept (0: never).
    walkers : int
        Walkers side by side (``/walker``, ``/walker_2``, ...).
    overrides : tuple of (str, str)
        Parameter values over the file's for every node of the graph (``-p NAME:=VALUE``).
    stop_timeout : float
        Wall-clock seconds each process is given to end on its interrupt at the shutdown.
    truss_survey : Path, optional
        A truss survey file (a walk's ``truss_survey.yaml``) the walk starts from (``None``:
        the nominal truss); with several walkers, every walker's.
    node_parameters : tuple of (str, str, str)
        ``(node, name, value)``: a parameter value for the nodes whose name matches the
        pattern ``node`` (:func:`fnmatch.fnmatchcase`, e.g. ``controller*``), over the file's
        and ``overrides``; a graph with a process per node only (processes, grouped).
    remaps : tuple of (str, str, str)
        ``(node, from, to)``: a topic remapping (``-r FROM:=TO``) for the nodes whose name
        matches ``node``; processes and grouped only.
    extra_nodes : tuple of NodeSpec
        Nodes started beside the walker's own, each in its own process, under the same
        supervision (e.g. a lossy link between two nodes, remapped to it); one walker only.
    handle_signals : bool
        Take SIGINT and SIGTERM while the graph runs (from the main thread), to stop a walk
        safely (code 130); ``False`` leaves the caller's handlers (a test runner's) in place.
    """

    arrangement: Arrangement = Arrangement.PROCESSES
    sim_time: bool = False
    record: bool = True
    report: bool = True
    out: Path | None = None
    namespace: str = '/walker'
    respawn: RespawnPolicy = RespawnPolicy()
    startup_timeout: float = 120.0
    walk_timeout: float = 600.0
    quiet: bool = False
    plant_params_file: Path | None = None
    transport: str | None = None
    realtime: int = 0
    foxglove_port: int | None = None
    bag_split: tuple[int, float, int] = NO_SPLIT
    walkers: int = 1
    overrides: tuple[tuple[str, str], ...] = ()
    stop_timeout: float = 10.0
    truss_survey: Path | None = None
    node_parameters: tuple[tuple[str, str, str], ...] = ()
    remaps: tuple[tuple[str, str, str], ...] = ()
    extra_nodes: tuple[NodeSpec, ...] = ()
    handle_signals: bool = True

    def __post_init__(self) -> None:
        """Refuse options that contradict each other (:class:`SessionError`, code 2)."""
        object.__setattr__(self, 'arrangement', Arrangement(self.arrangement))
        if self.arrangement is Arrangement.HEADLESS:
            graph_only = [name for name, given in (
                ('walkers', self.walkers > 1), ('foxglove_port', self.foxglove_port is not None),
                ('realtime', bool(self.realtime)), ('node_parameters', bool(self.node_parameters)),
                ('remaps', bool(self.remaps)), ('extra_nodes', bool(self.extra_nodes)))
                if given]
            if graph_only:
                raise SessionError(f'the headless runner runs no graph: leave '
                                   f'{", ".join(graph_only)} out')
        if self.walkers < 1:
            raise SessionError(f'walkers must be at least 1, got {self.walkers}')
        if self.plant_params_file is not None and self.walkers > 1:
            raise SessionError('a plant parameter file is for one walker: leave walkers out')
        if not self.walk_timeout > 0:  # nan too
            raise SessionError(f'walk_timeout must be > 0 s, got {self.walk_timeout}')
        self._check_node_settings()

    def _check_node_settings(self) -> None:
        """Refuse per-node settings of the wrong shape or that no process of a node takes."""
        for field in ('node_parameters', 'remaps'):
            for entry in getattr(self, field):
                if not (isinstance(entry, tuple) and len(entry) == 3
                        and all(isinstance(item, str) and item for item in entry)):
                    raise SessionError(f'{field} entries are (node, name, value) strings, got '
                                       f'{entry!r}')
        if (self.node_parameters or self.remaps) and (self.composed or self.composed_loop):
            raise SessionError(f'node_parameters and remaps are given to a process per node: '
                               f'the {self.arrangement} arrangement runs nodes in one process')
        for spec in self.extra_nodes:
            if not isinstance(spec, NodeSpec):
                raise SessionError(f'extra_nodes are NodeSpecs, got {spec!r}')
        if self.extra_nodes and self.walkers > 1:
            raise SessionError('extra_nodes are for one walker: leave walkers out')

    @property
    def composed(self) -> bool:
        """Each graph runs in one process."""
        return self.arrangement is Arrangement.COMPOSED

    @property
    def composed_loop(self) -> bool:
        """The loop (plant, controllers) runs in one process."""
        return self.arrangement is Arrangement.COMPOSED_LOOP

    @property
    def grouped_controllers(self) -> bool:
        """The five joint controllers run as one node (composed in sim time: by call)."""
        return self.arrangement in (Arrangement.GROUPED, Arrangement.COMPOSED_LOOP) \
            or (self.composed and self.sim_time)
