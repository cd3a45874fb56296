"""The workspace's tf2_msgs: Jazzy's interfaces and type hashes, skipped under a ROS install.

``/tf`` and ``/tf_static`` must carry the very type every ROS tool expects: a subscriber of
another type hash (RViz, tf2_ros, ``ros2 bag``) would not match our publishers on a full Jazzy
install. The expected hash is not computed here from our own files (that would only check the
build against itself): it is the one a real Jazzy build of geometry2's tf2_msgs generated,
read from a public workspace that committed its build tree
(``kuenem/Group-12_MotionPlanning-New``,
``build/tf2_msgs/rosidl_generator_c/tf2_msgs/msg/detail/tf_message__description.c``, the bytes
of ``tf2_msgs__msg__TFMessage__get_type_hash``); the same figure is the
``type_description_hash`` a Jazzy bag's ``metadata.yaml`` records for a TFMessage topic
(quoted in a public note on reading Jazzy bags in Humble). That file also records the hash it
expects of ``geometry_msgs/msg/TransformStamped``, which ties it to the Jazzy interfaces
installed here.
"""

from __future__ import annotations

import importlib.util
import os
import time
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]

#: RIHS01 of tf2_msgs/msg/TFMessage in ROS 2 Jazzy (source: the module docstring).
JAZZY_TF_MESSAGE_HASH = \
    'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'
#: RIHS01 of geometry_msgs/msg/TransformStamped that the same generated file expects.
JAZZY_TRANSFORM_STAMPED_HASH = \
    'RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206'


def _walker_env():
    spec = importlib.util.spec_from_file_location('walker_env_under_test',
                                                  REPO_ROOT / 'scripts' / 'walker_env.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_built_tf_message_has_jazzys_type_hash() -> None:
    from walker_bag.core.message_definitions import type_description_hash

    assert type_description_hash('geometry_msgs/msg/TransformStamped') == \
        JAZZY_TRANSFORM_STAMPED_HASH, "the installed geometry_msgs are not Jazzy's"
    assert type_description_hash('tf2_msgs/msg/TFMessage') == JAZZY_TF_MESSAGE_HASH


def test_a_tf_publisher_announces_jazzys_type_hash(rclpy_context) -> None:
    """What DDS discovery tells a subscriber on a full ROS install (USER_DATA typehash)."""
    from rclpy.node import Node
    from tf2_msgs.msg import TFMessage

    node = Node('tf_hash_probe', context=rclpy_context, start_parameter_services=False)
    try:
        node.create_publisher(TFMessage, '/tf_hash_probe', 1)
        deadline = time.monotonic() + 10.0
        endpoints = []
        while not endpoints and time.monotonic() < deadline:
            endpoints = node.get_publishers_info_by_topic('/tf_hash_probe')
            time.sleep(0.05)
        assert endpoints, 'the probe publisher never appeared in the graph'
        assert str(endpoints[0].topic_type_hash) == JAZZY_TF_MESSAGE_HASH
    finally:
        node.destroy_node()


def _underlay(tmp_path: Path, packages: tuple[str, ...]) -> Path:
    prefix = tmp_path / 'underlay'
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    for package in packages:
        (index / package).write_text('')
    return prefix


def _workspace(tmp_path: Path) -> Path:
    workspace = tmp_path / 'ws'
    (workspace / 'src' / 'tf2_msgs').mkdir(parents=True)
    (workspace / 'install' / 'tf2_msgs').mkdir(parents=True)
    (workspace / 'build' / 'tf2_msgs').mkdir(parents=True)
    return workspace


def test_an_underlay_with_tf2_msgs_makes_the_build_skip_ours(tmp_path: Path) -> None:
    env = _walker_env()
    workspace = _workspace(tmp_path)
    with_it = _underlay(tmp_path, ('geometry_msgs', 'tf2_msgs'))
    assert env.sync_stand_ins([str(tmp_path / 'other'), str(with_it)], workspace) == \
        {'tf2_msgs': False}
    assert (workspace / 'src' / 'tf2_msgs' / 'COLCON_IGNORE').is_file()
    # what an earlier build installed would shadow the underlay's own
    assert not (workspace / 'install' / 'tf2_msgs').exists()
    assert not (workspace / 'build' / 'tf2_msgs').exists()
    assert env.sync_stand_ins([str(with_it)], workspace) == {'tf2_msgs': False}  # idempotent


def test_an_underlay_without_tf2_msgs_builds_ours(tmp_path: Path) -> None:
    env = _walker_env()
    workspace = _workspace(tmp_path)
    ignore = workspace / 'src' / 'tf2_msgs' / 'COLCON_IGNORE'
    ignore.write_text('left by a run on a machine with ROS installed\n')
    without = _underlay(tmp_path, ('geometry_msgs',))
    assert env.sync_stand_ins([str(without)], workspace) == {'tf2_msgs': True}
    assert not ignore.exists()
    assert (workspace / 'install' / 'tf2_msgs').is_dir()


def test_this_set_up_builds_ours_where_the_underlay_lacks_tf2_msgs() -> None:
    env = _walker_env()
    venv = os.environ.get('VIRTUAL_ENV') or str(REPO_ROOT / '.venv')
    if env.underlay_provides('tf2_msgs', [venv]):
        pytest.fail('the virtual environment provides tf2_msgs now: drop the stand-in')
    workspace = str(REPO_ROOT / 'ros2_ws' / 'install')
    underlay = [prefix for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
                if prefix and not prefix.startswith(workspace)]
    ignored = (REPO_ROOT / 'ros2_ws' / 'src' / 'tf2_msgs' / 'COLCON_IGNORE').exists()
    if env.underlay_provides('tf2_msgs', underlay):  # a full ROS install sourced beneath
        assert ignored, "the underlay's tf2_msgs must not be shadowed by the workspace copy"
    else:
        assert not ignored, 'no underlay provides tf2_msgs: the workspace must build it'
