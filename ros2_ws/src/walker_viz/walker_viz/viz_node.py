"""The viz node: the walker's TF and markers (``ros2 run walker_viz viz_node``).

A robot_state_publisher that also knows where the robot holds the truss. Thin layer over
:mod:`walker_viz.core`; interfaces (relative to the node's namespace, normally ``/walker``):

* publishes ``/tf`` (the moving joints and the pose of the tree's root ``gripper_a`` in the
  ``truss`` frame, all of one instant, stamped with it): with ``viz.flexible`` every sample of
  ``flexible_joint_states`` (the five joints and the links' bends, at the plant's pose
  stamps), else the newest of ``joint_states`` (the five), every ``1 / viz.tf_rate``;
  ``/tf_static`` once (the joints that do not move: the bends without ``viz.flexible``; one
  latched message) and ``markers`` (``visualization_msgs/MarkerArray``, latched: the truss,
  the step's target node and the planned tip path; every message holds them all);
* subscribes to ``flexible_joint_states`` or ``joint_states`` (taken at the TF rate, not one
  callback per state; made anew when it falls silent while the clock runs on, see
  :mod:`walker_runtime.watched_subscription`), ``gripper_a_pose`` and ``gripper_b_pose``
  (where a simulator publishes them: the base gripper's measured pose places the tree, see
  :meth:`walker_viz.core.scene.WalkerScene.transforms`), ``gripper_states`` (which gripper is
  screwed into which node), ``phase`` and ``control_mode`` (the supervisor's base gripper, and the
  step's target node) and ``planned_trajectory`` (the path drawn).

Under ``use_sim_time`` the TF timer runs on the simulated clock. ``/tf`` is neither computed
nor sent while nobody subscribes to it (:mod:`walker_runtime.listened`). What is drawn is
decided by :class:`walker_viz.core.scene.WalkerScene`.
"""

from __future__ import annotations

import sys

import numpy as np
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from walker_core.gripper_state import reported_state
from walker_core.joint_roles import GRIPPERS
from walker_core.robot_parameters import WalkerParameters
from walker_runtime.core.resubscription import clock_ran_past
from walker_runtime.node_main import run_node
from walker_runtime.node_parameters import declare_section
from walker_runtime.qos import LATCHED_QOS, MODE_QOS, TF_QOS, TF_STATIC_QOS, latched_qos
from walker_runtime.listened import ListenedPublisher
from walker_runtime.spinning import TopicSampler
from walker_runtime.watched_subscription import SampledSubscription
from walker_msgs.msg import ControlMode, GripperStates, StepPhase
from walker_viz.core.measured_poses import MeasuredPoses
from walker_viz.core.parameters import VIZ_PREFIX, VizParameters
from walker_viz.core.robot_tree import WORLD_FRAME
from walker_viz.core.scene import WalkerScene
from walker_viz.messages import marker_array, pose_matrix, tf_message

__all__ = ['VizNode', 'main']

#: The supervisor's phase topic keeps a history; the newest is all this node needs.
_PHASE_QOS = latched_qos(1)
#: Flexible joint states wait to be drawn: many periods of the pose rate, while the plant
#: runs ahead of this node in sim time.
_STATES_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=64,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
#: [s] steady time the joint states may be silent, the clock running on, before their
#: subscription is made anew (a restarted plant, a graph frozen and resumed)
_RESUBSCRIBE_AFTER = 2.0
#: [ns] how far the ROS clock must run past the newest joint state for a silence to count
_CLOCK_AHEAD = 500_000_000


class VizNode(Node):
    """ROS node publishing the walker's TF and markers.

    Raises
    ------
    ParameterError
        If the parameters are invalid; the node refuses to start.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('viz', **kwargs)
        self.params = declare_section(self, WalkerParameters)
        self.settings = declare_section(self, VizParameters, VIZ_PREFIX)
        self.scene = WalkerScene(self.params, self.settings)
        self._newest_state: int | None = None  # [ns] stamp of the newest joint state drawn

        self._tf = ListenedPublisher(self.create_publisher(TFMessage, '/tf', TF_QOS))
        self._tf_static = self.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        self._markers = self.create_publisher(MarkerArray, 'markers', LATCHED_QOS)
        self._sampler = TopicSampler(f'{self.get_name()}_sampler', self.get_namespace(),
                                     self.context)
        self._joint_states = SampledSubscription(
            self._sampler, JointState,
            'flexible_joint_states' if self.settings.flexible else 'joint_states', _STATES_QOS,
            after=_RESUBSCRIBE_AFTER, logger=self.get_logger(),
            counts=self._clock_ran_past_the_states)
        self._measured = MeasuredPoses()
        self._poses = {g: self._sampler.subscribe(PoseStamped, f'gripper_{g}_pose', _STATES_QOS)
                       for g in GRIPPERS}
        self.create_subscription(GripperStates, 'gripper_states', self._on_grippers,
                                 LATCHED_QOS)
        self.create_subscription(StepPhase, 'phase', self._on_phase, _PHASE_QOS)
        self.create_subscription(ControlMode, 'control_mode', self._on_control_mode, MODE_QOS)
        self.create_subscription(JointTrajectory, 'planned_trajectory', self._on_plan,
                                 LATCHED_QOS)
        self._tf_static.publish(tf_message(self.scene.tree.static_transforms(),
                                           self.get_clock().now().to_msg()))
        self._publish_markers()
        self.create_timer(1.0 / self.settings.tf_rate, self._publish_tf)
        self.get_logger().info(
            f'publishing TF of {len(self.scene.tree.links)} links '
            f'({len(self.scene.tree.moving_joints)} moving joints at '
            f'{self.settings.tf_rate:g} Hz) in the {WORLD_FRAME} frame, and the truss of '
            f'{len(self.scene.truss.node_names)} nodes as markers')

    def destroy_node(self) -> None:
        """Destroy the node and the one its joint-state subscription lives on."""
        self._sampler.destroy()
        super().destroy_node()

    # ------------------------------------------------------------------ TF
    def _clock_ran_past_the_states(self) -> bool:
        return clock_ran_past(self.get_clock().now().nanoseconds, self._newest_state,
                              _CLOCK_AHEAD, self.get_parameter('use_sim_time').value)

    def _publish_tf(self) -> None:
        states = self._joint_states.take()
        self._joint_states.check()
        for gripper, subscription in self._poses.items():
            for pose in self._sampler.take(subscription):
                try:
                    self._measured.add(gripper, _ns(pose.header.stamp), pose_matrix(pose.pose))
                except ValueError:  # a zero quaternion: no pose to place the tree at
                    continue
        if states and not self._tf.heard:  # nobody draws it (walker_runtime.listened)
            self._newest_state = _ns(states[-1].header.stamp)
            return
        # the links' bends change within a period of their modes: every flexible sample is
        # drawn; straight links, the newest joint state
        for state in states if self.settings.flexible else states[-1:]:
            try:
                edges = self.scene.transforms(state.name, state.position,
                                              self._measured.at(_ns(state.header.stamp)))
            except ValueError as error:
                self.get_logger().warning(f'joint state not drawn: {error}',
                                          throttle_duration_sec=1.0)
                continue
            self._newest_state = _ns(state.header.stamp)
            self._tf.publish(tf_message(edges, state.header.stamp))

    # ------------------------------------------------------------------ inputs
    def _on_grippers(self, message: GripperStates) -> None:
        self.scene.grippers({g.name: (reported_state(g.state), g.node)
                             for g in message.grippers})

    def _take_base(self, gripper: str) -> None:
        try:
            changed = self.scene.base(gripper)
        except ValueError as error:
            self.get_logger().warning(f'base gripper ignored: {error}')
            return
        if changed:
            self._publish_markers()

    def _on_control_mode(self, message: ControlMode) -> None:
        self._take_base(message.base_gripper)

    def _on_phase(self, message: StepPhase) -> None:
        self._take_base(message.base_gripper)
        if self.scene.set_target(message.to_node):
            self._publish_markers()

    def _on_plan(self, message: JointTrajectory) -> None:
        try:
            drawn = self.scene.plan(message.joint_names,
                                    np.array([p.positions for p in message.points]))
        except ValueError as error:
            self.get_logger().warning(f'planned trajectory not drawn: {error}')
            return
        if drawn:
            self._publish_markers()

    # ------------------------------------------------------------------ markers
    def _publish_markers(self) -> None:
        self._markers.publish(marker_array(*self.scene.markers()))


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def main(args=None) -> int:
    """Run the viz node until shut down; exit codes of :mod:`walker_runtime.node_main`."""
    return run_node(VizNode, 'viz', args)


if __name__ == '__main__':
    sys.exit(main())
