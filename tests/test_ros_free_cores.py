"""The ROS-free rule, checked on the whole workspace: no core imports rclpy or an interface.

Every module of every ``core`` package or directory under ``ros2_ws/src``, and every module
of ``walker_core``, is read (not imported) by :mod:`ros_free`; the checker itself is proven on
small trees written for the test.
"""

import pytest
from package_tree import write_package
from ros_free import is_ros_module, ros_free_violations, workspace_modules
from ros_test_support import REPO_ROOT

SOURCE = REPO_ROOT / 'ros2_ws' / 'src'


def test_no_core_module_and_nothing_in_walker_core_imports_rclpy_or_an_interface():
    violations = ros_free_violations(SOURCE)
    assert not violations, 'ROS imports in the ROS-free layers:\n' + '\n'.join(
        map(str, violations))


def test_the_walk_finds_every_packages_cores_without_a_list():
    modules = workspace_modules(SOURCE)
    packages = {path.parent.name for path in SOURCE.glob('*/setup.py')}
    assert {name.split('.')[0] for name in modules} == packages
    assert 'walker_core.kinematics' in modules and 'walker_sim.core.plant' in modules
    assert not any('.test' in name or name.endswith('setup') for name in modules)


@pytest.mark.parametrize('name, ros', [
    ('rclpy', True), ('rclpy.node', True), ('rcl_interfaces.msg', True),
    ('sensor_msgs.msg', True), ('walker_msgs.msg', True), ('std_srvs.srv', True),
    ('builtin_interfaces.msg', True), ('rosidl_runtime_py', True),
    ('numpy', False), ('walker_core.kinematics', False), ('yaml', False),
    ('ament_index_python.packages', False),
])
def test_ros_modules_are_told_by_name(name, ros):
    assert is_ros_module(name) is ros


@pytest.fixture
def clean_tree(tmp_path):
    write_package(tmp_path, 'walker_core', {'model.py': 'import numpy\n'})
    write_package(tmp_path, 'demo', {
        'core/__init__.py': '',
        'core/law.py': 'from walker_core import model\nfrom . import helpers\n',
        'core/helpers.py': 'import math\n',
        'node.py': 'import rclpy\nfrom std_msgs.msg import String\nfrom demo.core import law\n',
    })
    return tmp_path


def test_a_clean_tree_passes_though_its_nodes_import_rclpy(clean_tree):
    assert ros_free_violations(clean_tree) == []


@pytest.mark.parametrize('relative, text, imported', [
    ('demo/demo/core/law.py', 'import rclpy\n', 'rclpy'),
    ('demo/demo/core/law.py', 'def later():\n    from sensor_msgs.msg import JointState\n',
     'sensor_msgs.msg'),
    ('demo/demo/core/law.py', 'import importlib\nM = importlib.import_module("rclpy.qos")\n',
     'rclpy.qos'),
    ('demo/demo/core/helpers.py', 'class A:\n    def f(self):\n        import rcl_interfaces\n',
     'rcl_interfaces'),
    ('demo/demo/core/extra/deep.py', 'from walker_msgs.msg import ControlMode\n',
     'walker_msgs.msg'),
    ('walker_core/walker_core/model.py', 'from rclpy.node import Node\n', 'rclpy.node'),
    ('walker_core/walker_core/sub/__init__.py', 'import geometry_msgs.msg\n', 'geometry_msgs.msg'),
])
def test_an_added_ros_import_in_a_core_or_in_walker_core_fails_the_check(
        clean_tree, relative, text, imported):
    path = clean_tree / relative
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.parent.name == 'extra':
        (path.parent / '__init__.py').write_text('')
    path.write_text(path.read_text() + text if path.exists() else text)
    violations = ros_free_violations(clean_tree)
    assert violations, f'{relative}: {text!r} was not found'
    assert all(v.imported == imported and v.path == path for v in violations)
    assert str(path) in str(violations[0]) and imported in str(violations[0])


def test_a_core_reaching_rclpy_through_a_node_module_fails_the_check(clean_tree):
    law = clean_tree / 'demo' / 'demo' / 'core' / 'law.py'
    law.write_text(law.read_text() + 'def publish():\n    from demo import node\n')
    violations = {(v.module, v.imported) for v in ros_free_violations(clean_tree)}
    assert violations == {('demo.core.law', 'rclpy'), ('demo.core.law', 'std_msgs.msg')}
    # a relative import of the node module is followed the same way
    law.write_text('from .. import node\n')
    assert {v.module for v in ros_free_violations(clean_tree)} == {'demo.core.law'}
