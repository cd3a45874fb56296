"""The scene: what the viz node draws from the grippers, the base, the phase and the plans."""

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_viz.core.parameters import VizParameters
from walker_viz.core.robot_tree import WORLD_FRAME
from walker_viz.core.scene import WalkerScene

PARAMS = load_walker_parameters()
TRUSS = Truss.from_parameters(PARAMS)
KIN = WalkerKinematics.from_parameters(PARAMS)
#: Base a in n1_1, gripper b in n2_1 (physical order)
START = list(KIN.inverse([0.0, TRUSS.spacing, 0.0, 0.0, 0.0]))
BOTH = {'a': ('attached', 'n1_1'), 'b': ('attached', 'n2_1')}


@pytest.fixture
def scene():
    return WalkerScene(PARAMS, VizParameters(tf_rate=50.0, flexible=False))


def _namespaces(scene) -> tuple[set[str], list[str]]:
    specs, deleted = scene.markers()
    return {spec.namespace for spec in specs}, deleted


def test_the_robot_is_placed_in_the_truss_only_while_a_gripper_holds_it(scene):
    free = {'a': ('free', ''), 'b': ('screwing', 'n2_1')}
    scene.grippers(free)
    edges = scene.transforms(PHYSICAL_JOINT_NAMES, START)
    assert len(edges) == 5 and all(edge.parent != WORLD_FRAME for edge in edges)
    scene.grippers(BOTH)
    root = [e for e in scene.transforms(PHYSICAL_JOINT_NAMES, START) if e.parent == WORLD_FRAME]
    assert len(root) == 1
    assert np.allclose(root[0].matrix[:2, 3], TRUSS.position('n1_1')[:2], atol=0.2)
    scene.grippers({'a': ('unscrewing', 'n1_1'), 'b': ('free', '')})
    assert any(e.parent == WORLD_FRAME for e in scene.transforms(PHYSICAL_JOINT_NAMES, START))


def test_a_joint_state_that_does_not_pair_up_is_refused(scene):
    with pytest.raises(ValueError, match='names but'):
        scene.transforms(PHYSICAL_JOINT_NAMES, START[:4])
    with pytest.raises(ValueError, match='no angle'):
        scene.transforms(PHYSICAL_JOINT_NAMES[:4], START[:4])
    assert scene.angles is None


def test_the_target_and_the_planned_path_are_drawn_and_a_new_base_drops_the_path(scene):
    assert _namespaces(scene)[1] == ['target', 'planned_tip_path']
    assert scene.set_target('n1_2') and not scene.set_target('n1_2')
    goal = KIN.inverse([TRUSS.spacing, 0.0, 0.0, 0.0, 0.0])
    rows = np.linspace(START, goal, 20)
    assert not scene.plan(PHYSICAL_JOINT_NAMES, rows)  # no joint state yet
    scene.grippers(BOTH)
    scene.transforms(PHYSICAL_JOINT_NAMES, START)
    assert scene.plan(PHYSICAL_JOINT_NAMES, rows)
    namespaces, deleted = _namespaces(scene)
    assert {'target', 'planned_tip_path'} <= namespaces and deleted == []
    assert not scene.base('a')  # the base it assumed: nothing changes
    assert scene.base('b') and scene.path is None
    assert _namespaces(scene)[1] == ['planned_tip_path']
    with pytest.raises(ValueError):
        scene.base('c')


def test_a_measured_base_pose_places_the_tree_where_the_simulator_has_the_base(scene):
    """A base tilted in its seat (which the joint angles cannot tell) is drawn tilted."""
    from walker_core.urdf import GRIPPER_LINKS
    from walker_viz.core.robot_tree import axis_rotation
    scene.grippers(BOTH)
    scene.base('b')
    tilted = np.eye(4)
    tilted[:3, :3] = axis_rotation(np.array([1.0, 0.0, 0.0]), 3e-4)
    tilted[:3, 3] = TRUSS.position('n2_1') + [0.0, 0.0, 1e-6]
    edges = scene.transforms(PHYSICAL_JOINT_NAMES, START, {'b': tilted})
    root = next(e.matrix for e in edges if e.parent == WORLD_FRAME)
    angles = dict(zip(PHYSICAL_JOINT_NAMES, START, strict=True))
    drawn_b = root @ scene.tree.link_in_root(GRIPPER_LINKS['b'], angles)
    np.testing.assert_allclose(drawn_b, tilted, atol=1e-12)
    modelled = next(e.matrix for e in scene.transforms(PHYSICAL_JOINT_NAMES, START)
                    if e.parent == WORLD_FRAME)  # no measurement: upright at the node
    assert np.linalg.norm(modelled[:3, 3] - root[:3, 3]) > 1e-4
    # the other gripper's measured pose alone does not place the tree
    other = next(e.matrix for e in scene.transforms(PHYSICAL_JOINT_NAMES, START, {'a': tilted})
                 if e.parent == WORLD_FRAME)
    np.testing.assert_allclose(other, modelled)


def test_measured_poses_are_kept_by_stamp_and_the_oldest_dropped():
    from walker_viz.core.measured_poses import MeasuredPoses
    poses = MeasuredPoses(capacity=2)
    for stamp in (10, 20, 30):
        poses.add('a', stamp, np.eye(4) * 1.0)
    poses.add('b', 30, np.eye(4))
    poses.add('b', 40, np.full((4, 4), np.nan))  # not finite: ignored
    assert poses.at(10) == {} and set(poses.at(30)) == {'a', 'b'} and poses.at(40) == {}
    with pytest.raises(ValueError, match='gripper'):
        poses.add('c', 50, np.eye(4))
