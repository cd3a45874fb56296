"""The truss map for people: frames and markers latched at first, and again when a survey lands."""

from types import SimpleNamespace

from builtin_interfaces.msg import Time
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_runtime.qos import LATCHED_QOS
from walker_supervisor.core.step_geometry import BaseFrame
from walker_supervisor.core.truss_map import TrussMap
from walker_supervisor.map_frames import MAP_MARKERS_TOPIC, MapFrames
from walker_viz.core.map_markers import NOMINAL_COLOR, SURVEYED_COLOR

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
FRAME = BaseFrame(TRUSS.position('n1_1'), 0.3)


class _Node:
    """Stands in for the supervisor node: keeps what each publisher was given."""

    def __init__(self):
        self.sent, self.qos = {}, {}

    def create_publisher(self, kind, topic, qos):
        self.sent[topic], self.qos[topic] = [], qos
        return SimpleNamespace(publish=self.sent[topic].append)

    def get_clock(self):
        return SimpleNamespace(now=lambda: SimpleNamespace(to_msg=Time))


def _rgb(r, g, b, *alpha) -> tuple:
    return tuple(round(float(v), 3) for v in (r, g, b))  # the message's colours are float32


def _status(message) -> dict[str, tuple]:
    """Node name -> colour (r, g, b) of its status disc."""
    return {m.text: _rgb(m.color.r, m.color.g, m.color.b) for m in message.markers
            if m.ns == 'truss_map_status'}


def test_the_map_is_latched_as_markers_and_again_only_when_a_survey_changes_it():
    survey = TrussMap(TRUSS, prior_std=0.002, joint_std=2e-4)
    node = _Node()
    frames = MapFrames(node, survey)
    assert node.qos[MAP_MARKERS_TOPIC] == LATCHED_QOS  # a late RViz or recorder gets it
    frames.publish_if_changed()
    frames.publish_if_changed()
    markers = node.sent[MAP_MARKERS_TOPIC]
    assert len(markers) == len(node.sent['/tf_static']) == 1, 'an unchanged map is not resent'
    nominal = _rgb(*NOMINAL_COLOR)
    assert set(_status(markers[0]).values()) == {nominal}
    assert sorted(_status(markers[0])) == sorted(TRUSS.node_names)
    assert all(m.header.frame_id == 'truss' for m in markers[0].markers)

    survey.anchor_at('n1_1')
    theta = KIN.inverse([*FRAME.to_base(TRUSS.position('n2_1') + [0.002, -0.001, 0.0]),
                         0.0, 0.0])
    survey.survey('n2_1', FRAME, 'n1_1', KIN, theta)
    frames.publish_if_changed()
    assert len(markers) == 2
    status = _status(markers[1])
    surveyed = _rgb(*SURVEYED_COLOR)
    assert status['n1_1'] == status['n2_1'] == surveyed
    assert {v for k, v in status.items() if k not in ('n1_1', 'n2_1')} == {nominal}
    ellipsoid = next(m for m in markers[1].markers
                     if m.ns == 'truss_map_uncertainty' and m.text == 'n2_1')
    assert ellipsoid.type == ellipsoid.SPHERE
    assert ellipsoid.pose.position.x == survey.position('n2_1')[0]
    # surveyed: smaller than the 2-sigma ellipsoid of the prior (8 mm across)
    assert max(ellipsoid.scale.x, ellipsoid.scale.y, ellipsoid.scale.z) < 0.008
