"""The walker's graph in one process: every node built from its class, spun by executors.

This is the rclpy counterpart of a component container: the nodes of :func:`walker_graph`
are instantiated in one process, each with exactly the ``--ros-args`` its own process would
get (``Node(cli_args=..., use_global_arguments=False)``), so names, namespaces, remappings and
parameters are the same; only the process boundary goes. ``ros2 run walker_bringup
composed_graph --sim-time`` runs it (its command line: :mod:`walker_bringup.composed_process`);
``run_all.py --composed`` starts it under the same supervision as the separate processes.

Executors: the plant and the five controllers share one executor, the one
:func:`walker_runtime.spinning.make_executor` selects (the events executor by default), in the
main thread (rclpy's ``SingleThreadedExecutor`` when they exchange by call, below). The
supervisor and the planner keep the default ``SingleThreadedExecutor``, as in their own
processes (their actions' executions await futures, which failed inside the events executor,
or made its every spin return at once), and so does the recorder (it subscribes to topics as
they appear, which the events executor does not pick up after a node was added); those three
share a second thread. The planner streams from its own thread (on the events executor), as
in its process. All threads share one Python interpreter: the whole graph gets at most one
core of Python; what it saves is the process boundary (no inter-process transport, no wake-up
of another process per message).

The loop by call: in sim time, with the five joint controllers as one node
(``--grouped-controllers``), the plant hands each state to the controllers and takes their
answer by a function call (``PlantNode.hand_states_to``) instead of two messages through DDS,
as Gazebo's ros2_control plugin runs its controllers inside the simulator; with the planner in
the process too, its stream takes each state by call first and hands its setpoints to the
controllers by call (``PlannerNode.stream_by_call``): the lock-step waits on no message. Every
topic is still published for the other subscribers. ``--only plant,controllers`` composes just
the loop, for the other nodes to run as processes of their own (``run_all.py
--composed-loop``).

Shutdown: SIGINT or SIGTERM stops the spinning, the recorder takes what it has received and
closes its bag, then every node is destroyed (the planner last: destroying it shuts the
context down).
"""

from __future__ import annotations

import dataclasses
import importlib
import sys
import threading
from collections.abc import Callable, Sequence

from walker_bringup.graph import NodeSpec

__all__ = ['Component', 'COMPONENTS', 'LOOP_NODES', 'APPEND_BAG', 'CompositionError',
           'ComposedGraph', 'component_of']

#: The nodes of the control loop, by their names in the graph (``--only``, ``run_all.py
#: --composed-loop``): the plant and the five joint controllers as one node.
LOOP_NODES = ('plant', 'controllers')

#: The recorder's override that continues its bag (``--append-bag``).
APPEND_BAG = ('recorder.append', 'true')

_SPIN_TIMEOUT = 0.1  # [s] longest wait before a spin loop checks for a stop again
# [s] the loop by call: longest slice of it between two turns of the executor (a turn serves
# one ready callback: longer slices starved the plant's heartbeat on a loaded machine)
_LOOP_SLICE = 0.002


@dataclasses.dataclass(frozen=True)
class Component:
    """How one executable of the graph is built as a node in the composed process.

    ``module``, ``class_name``: where the node class is (it takes ``Node``'s keyword
    arguments); ``default_executor``: the node needs rclpy's default ``SingleThreadedExecutor``
    (module notes); ``start``: a method to call once the node is built, as its ``main()`` does.
    """

    module: str
    class_name: str
    default_executor: bool = False
    start: str = ''

    def node_class(self) -> type:
        """Import and return the node class."""
        return getattr(importlib.import_module(self.module), self.class_name)


#: The node class of every executable of :func:`walker_graph`, by (package, executable).
COMPONENTS: dict[tuple[str, str], Component] = {
    ('walker_sim', 'plant_node'): Component('walker_sim.plant_node', 'PlantNode'),
    ('walker_control', 'joint_controller_node'): Component(
        'walker_control.joint_controller_node', 'JointControllerNode'),
    ('walker_control', 'joint_controllers_node'): Component(
        'walker_control.joint_controllers_node', 'JointControllersNode'),
    ('walker_planner', 'planner_node'): Component(
        'walker_planner.planner_node', 'PlannerNode', default_executor=True,
        start='start_streaming'),
    ('walker_supervisor', 'supervisor_node'): Component(
        'walker_supervisor.supervisor_node', 'SupervisorNode', default_executor=True),
    ('walker_bag', 'recorder_node'): Component(
        'walker_bag.recorder_node', 'RecorderNode', default_executor=True),
    ('walker_viz', 'viz_node'): Component('walker_viz.viz_node', 'VizNode'),
    ('walker_viz', 'foxglove_bridge'): Component('walker_viz.foxglove_bridge',
                                                 'FoxgloveBridge'),
}


class CompositionError(RuntimeError):
    """A node of the graph could not be built; the message names it and says why."""


def component_of(spec: NodeSpec) -> Component:
    """Return the component of a node spec.

    Raises
    ------
    CompositionError
        If the executable is not one the composed graph knows.
    """
    try:
        return COMPONENTS[(spec.package, spec.executable)]
    except KeyError:
        known = ', '.join(f'{p}/{e}' for p, e in COMPONENTS)
        raise CompositionError(f'{spec.full_name}: {spec.package}/{spec.executable} cannot be '
                               f'composed (known: {known})') from None


class ComposedGraph:
    """The nodes of a graph, built in this process in start order.

    Parameters
    ----------
    specs : sequence of NodeSpec
        The graph, as :func:`walker_graph` lists it.
    context : rclpy.context.Context
        An initialised context all nodes share.

    Raises
    ------
    CompositionError
        If a node refuses to start (invalid parameters, a bag that cannot be created, ...);
        the nodes already built are destroyed first.
    """

    def __init__(self, specs: Sequence[NodeSpec], context) -> None:
        from walker_runtime.node_parameters import fix_use_sim_time

        self.context = context
        self.nodes: list[tuple[NodeSpec, Component, object]] = []
        #: what exchanges by call: '' nothing, 'loop' the plant and the controllers, 'graph'
        #: the planner's stream too (see the module notes)
        self.loop_by_call = ''
        components = [component_of(spec) for spec in specs]
        try:
            for spec, component in zip(specs, components, strict=True):
                try:
                    node = component.node_class()(cli_args=spec.ros_arguments(),
                                                  use_global_arguments=False, context=context)
                except Exception as error:  # any refusal: report which node and why
                    raise CompositionError(f'{spec.full_name} refused to start: {error}') \
                        from error
                fix_use_sim_time(node)
                self.nodes.append((spec, component, node))
                if component.start:
                    getattr(node, component.start)()
            self._close_the_loop_by_call()
        except BaseException:
            self.destroy()
            raise

    def _close_the_loop_by_call(self) -> None:
        """In sim time, connect the plant and the grouped controllers by call (module notes)."""
        plants = [node for spec, _, node in self.nodes if spec.executable == 'plant_node']
        grouped = [node for spec, _, node in self.nodes
                   if spec.executable == 'joint_controllers_node']
        planners = [node for spec, _, node in self.nodes if spec.executable == 'planner_node']
        if len(plants) == 1 and len(grouped) == 1 and plants[0].sim_time \
                and len(grouped[0].joints) == 5:
            planner = planners[0] if len(planners) == 1 else None
            plants[0].hand_states_to(grouped[0], planner)
            if planner is not None:
                planner.stream_by_call(grouped[0].take_setpoints_by_call().push)
            self.loop_by_call = 'graph' if planner is not None else 'loop'

    def node(self, name: str):
        """Return the node built from the spec named ``name`` (e.g. ``'plant'``)."""
        for spec, _, node in self.nodes:
            if spec.name == name:
                return node
        raise KeyError(name)

    def spin(self, stop: Callable[[], bool]) -> None:
        """Spin every node until ``stop()`` is true or the context shuts down."""
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        from walker_runtime.spinning import freeze_start_up_objects, make_executor

        # The loop by call runs in this thread between turns of the executor, holding the
        # interpreter: the events executor's timers (a thread of their own) then fell behind
        # (the plant's 10 Hz heartbeat came once a second), rclpy's executor checks its timers
        # itself on each turn.
        fast = SingleThreadedExecutor(context=self.context) if self.loop_by_call \
            else make_executor(self.context)
        default = SingleThreadedExecutor(context=self.context)
        for _, component, node in self.nodes:
            (default if component.default_executor else fast).add_node(node)
        self._default_executor = default
        freeze_start_up_objects()  # as each node's own process does (walker_runtime.spinning)

        def running() -> bool:
            return rclpy.ok(context=self.context) and not stop()

        def spin_default() -> None:
            while running():
                default.spin_once(timeout_sec=_SPIN_TIMEOUT)

        thread = threading.Thread(target=spin_default, name='default-executor', daemon=True)
        thread.start()
        plant = self.node('plant') if self.loop_by_call else None
        try:
            while running():
                if plant is None:
                    fast.spin_once(timeout_sec=_SPIN_TIMEOUT)
                    continue
                # one turn of the executor, one slice of the loop by call (module notes)
                fast.spin_once(timeout_sec=0.0 if plant.handover_pending else _SPIN_TIMEOUT)
                plant.hand_over_states(_LOOP_SLICE)
        finally:
            thread.join(timeout=5.0)
            for _, component, node in self.nodes:
                if not component.default_executor:
                    fast.remove_node(node)
            fast.shutdown(timeout_sec=0.0)

    def destroy(self) -> None:
        """Close the recorder's bag (after taking what it received), destroy every node."""
        recorder = [node for spec, _, node in self.nodes if spec.executable == 'recorder_node']
        executor = getattr(self, '_default_executor', None)
        for node in recorder:
            if executor is not None:
                try:
                    node.drain(executor)
                except Exception as error:  # the bag is closed below in any case
                    print(f'[composed_graph] recorder drain failed: {error}', file=sys.stderr)
            node.close_bag()
        if executor is not None:
            for _, component, node in self.nodes:
                if component.default_executor:
                    executor.remove_node(node)
            executor.shutdown(timeout_sec=0.0)
            self._default_executor = None
        # The planner shuts the context down when destroyed (to stop its stream thread).
        last = [item for item in self.nodes if item[0].executable == 'planner_node']
        for spec, _, node in [i for i in reversed(self.nodes) if i not in last] + last:
            try:
                node.destroy_node()
            except Exception as error:  # keep destroying the others
                print(f'[composed_graph] destroying {spec.full_name}: {error}', file=sys.stderr)
        self.nodes = []
