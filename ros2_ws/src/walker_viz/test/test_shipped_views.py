"""The shipped Foxglove layout and RViz configuration show what the graph publishes."""

import json
from pathlib import Path

import yaml

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_viz.foxglove_layout import layout_json

CONFIG = Path(__file__).resolve().parents[1] / 'config'


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
