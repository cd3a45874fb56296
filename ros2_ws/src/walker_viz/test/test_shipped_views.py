"""The shipped Foxglove layout and RViz configuration show what the graph publishes."""

import json
from pathlib import Path

import yaml
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES
from walker_runtime.qos import IMAGE_QOS
from walker_sim.camera_publishers import image_topic, info_topic
from walker_viz.foxglove_layout import layout_json

CONFIG = Path(__file__).resolve().parents[1] / 'config'

#: RViz's names of the QoS policies (rviz_common's QoS property values).
_RVIZ_RELIABILITY = {ReliabilityPolicy.RELIABLE: 'Reliable',
                     ReliabilityPolicy.BEST_EFFORT: 'Best Effort'}
_RVIZ_DURABILITY = {DurabilityPolicy.VOLATILE: 'Volatile',
                    DurabilityPolicy.TRANSIENT_LOCAL: 'Transient Local'}


def _panels(node):
    """Every panel of a Foxglove layout (depth first, in layout order)."""
    if isinstance(node, dict):
        if node.get('type') == 'panel':
            yield node
        for value in node.values():
            yield from _panels(value)
    elif isinstance(node, list):
        for value in node:
            yield from _panels(value)


def test_the_foxglove_layout_is_what_the_sdk_builds():
    shipped = (CONFIG / 'walker.foxglove.json').read_text()
    assert shipped == layout_json('/walker'), \
        'regenerate: python -m walker_viz.foxglove_layout > config/walker.foxglove.json'
    text = json.dumps(json.loads(shipped))
    for path in ('/walker/robot_description', '/walker/markers', '/walker/truss_map_markers',
                 '/walker/phase.phase',
                 *(f'/walker/controllers/{j}/state.position_error' for j in PHYSICAL_JOINT_NAMES)):
        assert path in text, path
    assert '"fixedFrame": "truss"' in text


def test_the_foxglove_layout_shows_each_wrist_camera_with_its_calibration():
    images = [p['config']['imageMode'] for p in _panels(json.loads(layout_json('/walker')))
              if p['panelType'] == 'Image']
    assert [(i['imageTopic'], i['calibrationTopic']) for i in images] == [
        (f'/walker/{image_topic(g)}', f'/walker/{info_topic(g)}') for g in GRIPPERS]


def test_the_rviz_configuration_reads_the_latched_topics_in_the_truss_frame():
    config = yaml.safe_load((CONFIG / 'walker.rviz').read_text())
    manager = config['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == 'truss'
    displays = {d['Class']: d for d in manager['Displays']}
    model = displays['rviz_default_plugins/RobotModel']
    markers = [d for d in manager['Displays'] if d['Class'] == 'rviz_default_plugins/MarkerArray']
    assert 'rviz_default_plugins/TF' in displays
    assert model['Description Topic']['Value'] == '/walker/robot_description'
    assert sorted(m['Topic']['Value'] for m in markers) == ['/walker/markers',
                                                           '/walker/truss_map_markers']
    for topic in (model['Description Topic'], *(m['Topic'] for m in markers)):
        assert topic['Durability Policy'] == 'Transient Local'  # a late RViz still gets them


def test_the_rviz_configuration_shows_each_wrist_camera_as_the_plant_publishes_it():
    config = yaml.safe_load((CONFIG / 'walker.rviz').read_text())
    images = [d for d in config['Visualization Manager']['Displays']
              if d['Class'] == 'rviz_default_plugins/Image']
    assert [d['Topic']['Value'] for d in images] == [f'/walker/{image_topic(g)}'
                                                     for g in GRIPPERS]
    for display in images:
        topic = display['Topic']
        assert display['Enabled'] is True
        # A reliable reader of a reliable writer gets a frame's lost fragments again; a
        # mismatch (a reliable reader of a best-effort writer) would get no frame at all.
        assert topic['Reliability Policy'] == _RVIZ_RELIABILITY[IMAGE_QOS.reliability]
        assert topic['Durability Policy'] == _RVIZ_DURABILITY[IMAGE_QOS.durability]
        assert topic['Depth'] == IMAGE_QOS.depth
