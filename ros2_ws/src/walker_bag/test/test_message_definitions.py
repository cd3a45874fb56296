"""Schema texts of the walk's types: rosbag2's layout, complete, and true to the type hashes."""

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from walker_bag.core.errors import MessageDefinitionError
from walker_bag.core.message_definitions import (
    SEPARATOR, interface_prefixes, message_definition, split_type_name, type_description_hash)

from walker_bag_samples import WALK_TOPICS

WALK_TYPES = sorted({type_name for _, type_name, _ in WALK_TOPICS})


def sections(text):
    """``[(type name, text)]`` of a concatenated definition, the root first (name None)."""
    parts = text.split('\n' + SEPARATOR)
    result = [(None, parts[0])]
    for part in parts[1:]:
        header, body = part.split('\n', 1)
        assert header.startswith('MSG: '), header
        result.append((header[len('MSG: '):], body))
    return result


def installed_msg_text(type_name):
    package, namespace, name = split_type_name(type_name)
    for prefix in interface_prefixes():
        path = prefix / 'share' / package / namespace / f'{name}.msg'
        if path.is_file():
            return path.read_text()
    raise AssertionError(f'{type_name} is not installed')


@pytest.mark.parametrize('type_name', WALK_TYPES)
def test_definition_is_the_installed_msg_text_then_each_dependency_once(type_name):
    definition = message_definition(type_name)
    assert definition.type_name == type_name
    assert definition.encoding == 'ros2msg'
    parts = sections(definition.text)
    assert parts[0][1] == installed_msg_text(type_name)
    names = [name for name, _ in parts[1:]]
    assert len(names) == len(set(names)), names
    for name, body in parts[1:]:
        assert '/msg/' not in name  # rosbag2 names dependencies pkg/Type
        package, _, short = name.partition('/')
        assert body == installed_msg_text(f'{package}/msg/{short}')


@pytest.mark.parametrize('type_name, needed', [
    ('sensor_msgs/msg/JointState', {'std_msgs/Header', 'builtin_interfaces/Time'}),
    ('walker_msgs/msg/GripperStates',
     {'walker_msgs/GripperState', 'std_msgs/Header', 'builtin_interfaces/Time'}),
    ('trajectory_msgs/msg/JointTrajectory',
     {'trajectory_msgs/JointTrajectoryPoint', 'builtin_interfaces/Duration', 'std_msgs/Header',
      'builtin_interfaces/Time'}),
    ('geometry_msgs/msg/PoseStamped',
     {'std_msgs/Header', 'builtin_interfaces/Time', 'geometry_msgs/Pose',
      'geometry_msgs/Point', 'geometry_msgs/Quaternion'}),
])
def test_every_type_used_is_included(type_name, needed):
    names = {name for name, _ in sections(message_definition(type_name).text)[1:]}
    assert names == needed


@pytest.mark.parametrize('type_name', WALK_TYPES)
def test_an_independent_parser_rebuilds_the_type_with_the_hash_ros_publishes(type_name):
    """Parse each section with rosbags: the RIHS01 hash equals the installed type hash."""
    store = get_typestore(Stores.EMPTY)
    types = {}
    for name, body in sections(message_definition(type_name).text):
        if name is None:
            types.update(get_types_from_msg(body, type_name))
        else:
            package, _, short = name.partition('/')
            types.update(get_types_from_msg(body, f'{package}/msg/{short}'))
    store.register(types)
    assert store.hash_rihs01(type_name) == type_description_hash(type_name)


def test_type_hash_has_the_rihs01_form():
    digest = type_description_hash('walker_msgs/msg/StepPhase')
    assert digest.startswith('RIHS01_')
    assert len(digest) == len('RIHS01_') + 64
    int(digest[len('RIHS01_'):], 16)


@pytest.mark.parametrize('name', ['walker_msgs/msg/NoSuchType', 'no_such_pkg/msg/Thing'])
def test_an_unknown_type_is_refused_by_name(name):
    with pytest.raises(MessageDefinitionError, match=name):
        message_definition(name)
    with pytest.raises(MessageDefinitionError, match=name):
        type_description_hash(name)


@pytest.mark.parametrize('name', ['', 'JointState', 'sensor_msgs/msg/Joint State',
                                  '1pkg/msg/T', 'a/b/c/d'])
def test_a_malformed_type_name_is_refused(name):
    with pytest.raises(MessageDefinitionError, match='not a ROS 2 message type name'):
        message_definition(name)


def test_a_missing_dependency_is_named(tmp_path):
    msg_dir = tmp_path / 'share' / 'demo_msgs' / 'msg'
    msg_dir.mkdir(parents=True)
    (msg_dir / 'Outer.msg').write_text('Inner inner\nfloat64 x\n')
    with pytest.raises(MessageDefinitionError, match='demo_msgs/Inner'):
        message_definition('demo_msgs/msg/Outer', [tmp_path])


def test_relative_field_types_resolve_in_their_package_and_comments_are_kept(tmp_path):
    msg_dir = tmp_path / 'share' / 'demo_msgs' / 'msg'
    msg_dir.mkdir(parents=True)
    (msg_dir / 'Outer.msg').write_text('# a comment naming Ghost type\nInner[] inner\n'
                                       'uint8 KIND = 1  # constant\n')
    (msg_dir / 'Inner.msg').write_text('float64 x  # [m]\n')
    definition = message_definition('demo_msgs/msg/Outer', [tmp_path])
    assert definition.text == ('# a comment naming Ghost type\nInner[] inner\n'
                               'uint8 KIND = 1  # constant\n\n' + SEPARATOR
                               + 'MSG: demo_msgs/Inner\nfloat64 x  # [m]\n')


def test_an_interface_defined_only_in_idl_falls_back_to_the_idl_text(tmp_path):
    msg_dir = tmp_path / 'share' / 'demo_msgs' / 'msg'
    msg_dir.mkdir(parents=True)
    (msg_dir / 'Only.idl').write_text('module demo_msgs { module msg { struct Only {\n'
                                      '  double x; }; }; };\n')
    definition = message_definition('demo_msgs/msg/Only', [tmp_path])
    assert definition.encoding == 'ros2idl'
    assert definition.text.startswith(SEPARATOR + 'IDL: demo_msgs/msg/Only\nmodule demo_msgs')
