"""A controller put in a mode nobody commanded is put back at once by the supervisor.

The whole graph runs as separate processes in sim time, idle in its start stance. Another
publisher writes one ``control_mode`` COARSE in the supervisor's name (``commander:
/walker/supervisor``; without SROS2 the field authenticates nothing): the controllers take it.
The supervisor, watching each controller's reported mode against the HOLD the idle walker is in,
commands HOLD again at once, says so on its console, and the phase stays IDLE.
"""

import time

import pytest

from ros_test_support import log_tails, ros_environment, running_graph

pytestmark = pytest.mark.integration

STARTUP_TIMEOUT = 120.0  # [s] wall, for the graph to come up on a loaded machine
CORRECTION_TIMEOUT = 60.0  # [s] wall, for the correction to show on a loaded machine


class Graph:
    """The idle graph, a client that hears the controllers' states and the phase."""

    def __init__(self, tmp, domain: int) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from walker_msgs.msg import ControlMode, ControllerState, GripperStates, StepPhase

        from walker_bringup.graph import walker_graph
        from walker_bringup.graph_client import GraphClient, init_context
        from walker_bringup.processes import ProcessGroup
        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
        from walker_core.robot_parameters import default_parameter_file
        from walker_runtime.qos import MODE_QOS

        self.env = ros_environment(domain)
        self.nodes = walker_graph(default_parameter_file(), sim_time=True)
        self.group = ProcessGroup(tmp / 'logs', self.env)
        self.context = self.client = None
        self.gripper_states, self.phases, self.modes = [], [], {}
        try:
            for spec in self.nodes:
                self.group.start(spec)
            self.context = init_context(domain)
            self.client = GraphClient('/walker', self.context)
            node = self.client.node
            latched = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
            node.create_subscription(GripperStates, 'gripper_states',
                                     self.gripper_states.append, latched)
            node.create_subscription(StepPhase, 'phase', self.phases.append, latched)
            for joint in PHYSICAL_JOINT_NAMES:
                node.create_subscription(
                    ControllerState, f'controllers/{joint}/state',
                    lambda msg, joint=joint: self.modes.__setitem__(joint, msg.mode),
                    QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
            self.rogue = node.create_publisher(ControlMode, 'control_mode', MODE_QOS)
            self.client.wait_until_ready([n.full_name for n in self.nodes], STARTUP_TIMEOUT,
                                         should_stop=lambda: bool(self.group.poll_deaths()))
        except BaseException:  # a graph that did not come up is stopped, not left running
            self.close()
            raise

    def close(self) -> dict:
        if self.client is not None:
            self.client.close()
        if self.context is not None:
            self.context.try_shutdown()
        return self.group.stop_all()

    def wait_for(self, condition, what: str) -> None:
        deadline = time.monotonic() + CORRECTION_TIMEOUT
        while not condition():
            assert time.monotonic() < deadline, \
                f'waited {CORRECTION_TIMEOUT:g} s for {what}\n' + log_tails(self.group,
                                                                            ['supervisor'])
            self.client.spin_for(0.1)

    def supervisor_log(self) -> str:
        return log_tails(self.group, ['supervisor'], lines=400)


@pytest.fixture
def graph(tmp_path):
    with running_graph(Graph, tmp_path) as running:
        yield running


def test_a_mode_written_in_the_supervisors_name_is_corrected_at_once(graph):
    from walker_msgs.msg import ControlMode, ControllerState, StepPhase

    graph.wait_for(lambda: len(graph.modes) == 5
                   and set(graph.modes.values()) == {ControllerState.HOLD}, 'the idle HOLD')
    graph.rogue.publish(ControlMode(mode=ControlMode.COARSE, base_gripper='a',
                                    commander='/walker/supervisor'))
    graph.wait_for(lambda: 'no command of this supervisor' in graph.supervisor_log(),
                   'the supervisor to notice the rogue mode')
    graph.modes.clear()
    graph.wait_for(lambda: len(graph.modes) == 5, 'fresh controller states')
    graph.wait_for(lambda: set(graph.modes.values()) == {ControllerState.HOLD},
                   'every controller back in HOLD')
    assert 'COARSE' in graph.supervisor_log()
    assert graph.phases and all(p.phase == StepPhase.IDLE for p in graph.phases), \
        [p.phase for p in graph.phases]
