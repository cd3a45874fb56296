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
  :mod:`walker_runtime.watched_subscription`), ``gripper_states`` (which gripper is screwed
  into which node), ``phase`` and ``control_mode`` (the supervisor's base gripper, and the
  step's target node) and ``planned_trajectory`` (the path drawn).

Under ``use_sim_time`` the TF timer runs on the simulated clock.
"""

from __future__ import annotations

import sys

import numpy as np
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from walker_core.robot_parameters import WalkerParameters
from walker_core.truss import Truss, UnknownNodeError
from walker_core.urdf import robot_urdf
from walker_runtime.core.resubscription import clock_ran_past
from walker_runtime.node_main import run_node
from walker_runtime.node_parameters import declare_section
from walker_runtime.qos import LATCHED_QOS, MODE_QOS, TF_QOS, TF_STATIC_QOS, latched_qos
from walker_runtime.spinning import TopicSampler
from walker_runtime.watched_subscription import SampledSubscription
from walker_msgs.msg import ControlMode, GripperState, GripperStates, StepPhase
from walker_viz.core.base_anchor import BaseTracker
from walker_viz.core.markers import (
    target_marker, tip_path, tip_path_marker, truss_markers)
from walker_viz.core.parameters import VIZ_PREFIX, VizParameters
from walker_viz.core.robot_tree import WORLD_FRAME, JointTransform, RobotTree
from walker_viz.messages import marker_array, tf_message

__all__ = ['VizNode', 'main']

#: Gripper states in which a gripper is in its hole, holding.
_HOLDING = (GripperState.ATTACHED, GripperState.UNSCREWING)
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
        self.truss = Truss.from_parameters(self.params)
        self.tree = RobotTree(robot_urdf(self.params, flexible=self.settings.flexible,
                                         rotors=False))
        self.tracker = BaseTracker(self.tree, self.truss)
        self._angles: dict[str, float] | None = None
        self._newest_state: int | None = None  # [ns] stamp of the newest joint state drawn
        self._target: str = ''
        self._path: np.ndarray | None = None

        self._tf = self.create_publisher(TFMessage, '/tf', TF_QOS)
        self._tf_static = self.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        self._markers = self.create_publisher(MarkerArray, 'markers', LATCHED_QOS)
        self._sampler = TopicSampler(f'{self.get_name()}_sampler', self.get_namespace(),
                                     self.context)
        self._joint_states = SampledSubscription(
            self._sampler, JointState,
            'flexible_joint_states' if self.settings.flexible else 'joint_states', _STATES_QOS,
            after=_RESUBSCRIBE_AFTER, logger=self.get_logger(),
            counts=self._clock_ran_past_the_states)
        self.create_subscription(GripperStates, 'gripper_states', self._on_grippers,
                                 LATCHED_QOS)
        self.create_subscription(StepPhase, 'phase', self._on_phase, _PHASE_QOS)
        self.create_subscription(ControlMode, 'control_mode', self._on_control_mode, MODE_QOS)
        self.create_subscription(JointTrajectory, 'planned_trajectory', self._on_plan,
                                 LATCHED_QOS)
        self._truss_markers = truss_markers(self.truss, self.params.truss.hole_depth)
        self._tf_static.publish(tf_message(self.tree.static_transforms(),
                                           self.get_clock().now().to_msg()))
        self._publish_markers()
        self.create_timer(1.0 / self.settings.tf_rate, self._publish_tf)
        self.get_logger().info(
            f'publishing TF of {len(self.tree.links)} links ({len(self.tree.moving_joints)} '
            f'moving joints at {self.settings.tf_rate:g} Hz) in the {WORLD_FRAME} frame, and '
            f'the truss of {len(self.truss.node_names)} nodes as markers')

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
        # the links' bends change within a period of their modes: every flexible sample is
        # drawn; straight links, the newest joint state
        for state in states if self.settings.flexible else states[-1:]:
            try:
                if len(state.name) != len(state.position):
                    raise ValueError(f'{len(state.name)} names but {len(state.position)} '
                                     'positions')
                angles = dict(zip(state.name, state.position, strict=True))
                edges = self.tree.moving_transforms(angles)
            except ValueError as error:
                self.get_logger().warning(f'joint state not drawn: {error}',
                                          throttle_duration_sec=1.0)
                continue
            self._angles = angles
            self._newest_state = state.header.stamp.sec * 1_000_000_000 + \
                state.header.stamp.nanosec
            root = self.tracker.root_pose(angles)
            if root is not None:
                edges.append(JointTransform(WORLD_FRAME, self.tree.root, root))
            self._tf.publish(tf_message(edges, state.header.stamp))

    # ------------------------------------------------------------------ inputs
    def _on_grippers(self, message: GripperStates) -> None:
        self.tracker.set_attached({g.name: g.node for g in message.grippers
                                   if g.state in _HOLDING})

    def _take_base(self, gripper: str) -> None:
        try:
            changed = self.tracker.set_base(gripper)
        except ValueError as error:
            self.get_logger().warning(f'base gripper ignored: {error}')
            return
        if changed and self._path is not None:
            self._path = None  # planned from the other base
            self._publish_markers()

    def _on_control_mode(self, message: ControlMode) -> None:
        self._take_base(message.base_gripper)

    def _on_phase(self, message: StepPhase) -> None:
        self._take_base(message.base_gripper)
        if message.to_node != self._target:
            self._target = message.to_node
            self._publish_markers()

    def _on_plan(self, message: JointTrajectory) -> None:
        if self._angles is None or not message.points:
            return
        anchor = self.tracker.anchor(self._angles)
        if anchor is None:
            return
        try:
            self._path = tip_path(self.tree, anchor, list(message.joint_names),
                                  np.array([p.positions for p in message.points]))
        except ValueError as error:
            self.get_logger().warning(f'planned trajectory not drawn: {error}')
            return
        self._publish_markers()

    # ------------------------------------------------------------------ markers
    def _publish_markers(self) -> None:
        specs = list(self._truss_markers)
        deleted = []
        try:
            specs.append(target_marker(self.truss, self._target))
        except UnknownNodeError:
            deleted.append('target')
        if self._path is not None and len(self._path) > 1:
            specs.append(tip_path_marker(self._path))
        else:
            deleted.append('planned_tip_path')
        self._markers.publish(marker_array(specs, deleted))


def main(args=None) -> int:
    """Run the viz node until shut down; exit codes of :mod:`walker_runtime.node_main`."""
    return run_node(VizNode, 'viz', args)


if __name__ == '__main__':
    sys.exit(main())
