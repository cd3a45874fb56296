"""The wrist cameras' topics in a headless walk's bag, as the graph's recorder writes them.

With cameras on (``gripper.camera.enabled``), the graph's plant publishes each frame a look
asks for on ``camera_<g>/image_raw`` (``sensor_msgs/Image``, ``rgb8``) and
``camera_<g>/camera_info`` (``sensor_msgs/CameraInfo``) with the frame's truth on
``camera_<g>/true_hole``, and the supervisor what it measured in it on ``camera_<g>/hole``
(both ``geometry_msgs/PointStamped`` in the gripper's frame); the recorder records them
(``walker_bringup.graph.RECORDED_TOPICS``). :class:`CameraRecording` adds the same topics, with
the same types and offered QoS, to a :class:`~walker_headless.recording.WalkRecording` and writes
the same messages, serialized by rosbags: stamped with the frame's exposure, logged at the
simulated time the loop hands the frame over (its ``ready_time``, as the graph's plant sends it
at its first state at or after it).
"""

from __future__ import annotations

import numpy as np

from walker_bag.core.qos import QosProfile
from walker_core.camera import (
    CAMERA_INFO, HOLE, IMAGE, PLUMB_BOB, TRUE_HOLE, CameraModel, camera_topic,
    optical_frame_name)
from walker_core.joint_roles import GRIPPERS
from walker_core.urdf import GRIPPER_LINKS

__all__ = ['CameraRecording', 'CAMERA_TOPICS']

_IMAGE_TYPE = 'sensor_msgs/msg/Image'
_INFO_TYPE = 'sensor_msgs/msg/CameraInfo'
_POINT_TYPE = 'geometry_msgs/msg/PointStamped'
#: Each camera topic's type (``camera_<g>/<name>``); all offered reliable and volatile
#: (``walker_runtime.qos.IMAGE_QOS``), as the recorder stores them.
CAMERA_TOPICS = {IMAGE: _IMAGE_TYPE, CAMERA_INFO: _INFO_TYPE, TRUE_HOLE: _POINT_TYPE,
                 HOLE: _POINT_TYPE}
_RELIABLE = QosProfile('reliable', 'volatile')
_NS_PER_S = 1_000_000_000


def _stamp(seconds: float) -> int:
    """[ns] of a time [s], as the frame's stamp (the graph's stamps are whole nanoseconds)."""
    return round(seconds * _NS_PER_S)


class CameraRecording:
    """The camera topics of both grippers in a walk's bag.

    Parameters
    ----------
    recording : WalkRecording
        The walk's bag; the topics are added to it now.
    model : CameraModel
        The nominal camera (its calibration goes on ``camera_info``).
    """

    def __init__(self, recording, model: CameraModel) -> None:
        self._recording = recording
        self._types = recording.types
        self._info = model.plumb_bob()
        recording.add_topics({camera_topic(gripper, name): (type_name, _RELIABLE)
                              for gripper in GRIPPERS
                              for name, type_name in CAMERA_TOPICS.items()})

    def frame(self, log_stamp: int, frame) -> None:
        """Write a frame's image, calibration and truth, logged at ``log_stamp`` [ns].

        ``frame`` is the plant's :class:`~walker_sim.core.wrist_camera.CameraFrame`.
        """
        t, gripper, serialize = self._types, frame.gripper, self._recording.serialize
        exposure = _stamp(frame.exposure_time)
        optical = self._recording.header(exposure, optical_frame_name(gripper))
        rows, columns, _ = frame.image.shape
        serialize(camera_topic(gripper, IMAGE), t[_IMAGE_TYPE](
            header=optical, height=rows, width=columns, encoding='rgb8', is_bigendian=0,
            step=3 * columns, data=np.ascontiguousarray(frame.image, dtype=np.uint8).reshape(-1)),
            log_stamp)
        info = self._info
        serialize(camera_topic(gripper, CAMERA_INFO), t[_INFO_TYPE](
            header=optical, height=info.height, width=info.width, distortion_model=PLUMB_BOB,
            d=np.array(info.d, dtype=np.float64), k=np.array(info.k, dtype=np.float64),
            r=np.array(info.r, dtype=np.float64), p=np.array(info.p, dtype=np.float64),
            binning_x=0, binning_y=0,
            roi=t['sensor_msgs/msg/RegionOfInterest'](x_offset=0, y_offset=0, height=0, width=0,
                                                      do_rectify=False)), log_stamp)
        self._point(gripper, TRUE_HOLE, exposure, frame.mouth_in_gripper, log_stamp)

    def hole(self, log_stamp: int, sighted) -> None:
        """Write the hole a frame showed (the runner's ``HoleSighted``) at ``log_stamp`` [ns]."""
        self._point(sighted.gripper, HOLE, _stamp(sighted.exposure_time), sighted.point,
                    log_stamp)

    def _point(self, gripper: str, name: str, stamp: int, point, log_stamp: int) -> None:
        t = self._types
        x, y, z = (float(v) for v in point)
        self._recording.serialize(camera_topic(gripper, name), t[_POINT_TYPE](
            header=self._recording.header(stamp, GRIPPER_LINKS[gripper]),
            point=t['geometry_msgs/msg/Point'](x=x, y=y, z=z)), log_stamp)
