"""The QoS profiles of the walker's topics, one definition for every publisher and subscriber.

docs/architecture.md gives each topic its QoS; a publisher and a subscriber of one topic must
agree (a best-effort publisher never reaches a reliable subscriber, and a volatile one never
replays to a transient-local late joiner), and the recorder stores what the first publishers
offer. So every node takes its profiles from here:

* :data:`SENSOR_QOS`: high-rate state (``joint_states``, ``joint_accelerations``, the poses):
  best effort, newest only; a slow subscriber never stalls the plant.
* :data:`COMMAND_QOS`: commands and reports every period (``effort_commands``, the
  setpoints, the controller states, ``/diagnostics``): reliable, keep last 10.
* :data:`LATCHED_QOS`: latched state (``gripper_states``, ``robot_description``,
  ``planned_trajectory``): reliable, transient local, depth 1.
* :data:`MODE_QOS`: the supervisor's ``control_mode`` publisher: latched, depth 1, so that a late
  subscriber gets the mode commanded now; :data:`MODE_SUBSCRIPTION_QOS`, its receivers (the
  controllers, the planner): latched with depth 10, since a step's final HOLD and the next
  step's mode follow each other within milliseconds and each must be handled, none overwritten
  in the receiver's queue before its callback took it (publication is synchronous: each
  command leaves the supervisor as it is published).
* :data:`CLOCK_QOS`: ``/clock``: reliable, keep last 1.
* :data:`IMAGE_QOS`: the wrist cameras' ``image_raw`` and ``camera_info``: reliable, keep last
  1. A frame of hundreds of kilobytes travels in UDP fragments that can overflow a reader's
  socket buffer on a loaded machine: one fragment lost loses a best-effort frame whole, where
  reliable delivery sends it again. The newest only, so a slow reader never stalls the plant.
  The points beside each frame (``true_hole``, ``hole``) share it.
* :data:`LOOK_IMAGE_QOS`: the plant's ``image_raw`` writer and the supervisor's reader: as
  :data:`IMAGE_QOS` but keep last 5, every frame of one look (``look_frames``, at most 5).
  A frame takes longer to render than a look's frames are apart, so two can be sent within
  milliseconds: with one kept, the reader's newer frame replaced the older before its callback
  took it, and the look waited for a frame it would never get. Keep last never blocks the
  writer: a slow reader still cannot stall the plant.
* :func:`latched_qos`: latched with a history (the phase, the step reports).
* :data:`TF_QOS` and :data:`TF_STATIC_QOS`: ``/tf`` and ``/tf_static`` as tf2_ros offers them
  (``DynamicBroadcasterQoS``: reliable, keep last 100; ``StaticBroadcasterQoS``: reliable,
  transient local, keep last 1, every static transform in one message), so that RViz, tf2
  listeners and ``ros2 bag`` match them unchanged.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['SENSOR_QOS', 'COMMAND_QOS', 'LATCHED_QOS', 'MODE_QOS', 'MODE_SUBSCRIPTION_QOS',
           'CLOCK_QOS', 'IMAGE_QOS', 'LOOK_IMAGE_QOS', 'TF_QOS', 'TF_STATIC_QOS', 'latched_qos']


def latched_qos(depth: int) -> QoSProfile:
    """Reliable, transient local, keep last ``depth``: a late subscriber gets the last ones.

    Raises
    ------
    ValueError
        If ``depth`` is not a positive integer.
    """
    if isinstance(depth, bool) or not isinstance(depth, int) or depth < 1:
        raise ValueError(f'a latched topic keeps at least one message, got depth {depth!r}')
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                        reliability=ReliabilityPolicy.BEST_EFFORT,
                        durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
LATCHED_QOS = latched_qos(1)
MODE_QOS = latched_qos(1)
MODE_SUBSCRIPTION_QOS = latched_qos(10)
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
IMAGE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
LOOK_IMAGE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                            reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.VOLATILE)
TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = latched_qos(1)
