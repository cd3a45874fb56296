"""Physical joints and the roles J1..J5 they play depending on which gripper is the base.

The walker is symmetric. Its physical joints, from gripper ``a`` to gripper ``b``, are
``a_yaw_joint, a_pitch_joint, vertex_joint, b_pitch_joint, b_yaw_joint``. With gripper ``a`` as
the base they play the roles J1..J5 in that order; after a step gripper ``b`` is the base and the
roles mirror (J1<->J5, J2<->J4). The joint axes are defined so that mirroring is a pure reversal
with no change of sign (see :mod:`walker_core.kinematics`), so role angles are a permutation of
physical angles.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    'GRIPPERS', 'PHYSICAL_JOINT_NAMES', 'other_gripper', 'role_permutation',
    'physical_to_roles', 'roles_to_physical', 'role_of_joint', 'joint_of_role',
    'validate_gripper',
]

GRIPPERS = ('a', 'b')
PHYSICAL_JOINT_NAMES = ('a_yaw_joint', 'a_pitch_joint', 'vertex_joint',
                        'b_pitch_joint', 'b_yaw_joint')


def validate_gripper(gripper: str) -> str:
    """Return ``gripper`` if it names a gripper, else raise ValueError naming it."""
    if gripper not in GRIPPERS:
        raise ValueError(f'unknown gripper {gripper!r}: expected "a" or "b"')
    return gripper


def other_gripper(gripper: str) -> str:
    """Return the gripper that is not ``gripper``."""
    return 'b' if validate_gripper(gripper) == 'a' else 'a'


def role_permutation(base: str) -> tuple[int, ...]:
    """Physical joint index of each role J1..J5 (0-based) for the given base gripper."""
    return (0, 1, 2, 3, 4) if validate_gripper(base) == 'a' else (4, 3, 2, 1, 0)


def physical_to_roles(values_physical: np.ndarray, base: str) -> np.ndarray:
    """Reorder per-joint values (angles, torques, ...) from physical order to role order."""
    values = np.asarray(values_physical, dtype=float)
    if values.shape[-1] != 5:
        raise ValueError(f'expected 5 joint values, got shape {values.shape}')
    return values[..., list(role_permutation(base))]


def roles_to_physical(values_roles: np.ndarray, base: str) -> np.ndarray:
    """Reorder per-joint values from role order J1..J5 to physical order.

    The permutation is its own inverse, so this equals :func:`physical_to_roles`.
    """
    return physical_to_roles(values_roles, base)


def role_of_joint(joint_name: str, base: str) -> int:
    """Role number 1..5 of a physical joint for the given base gripper."""
    if joint_name not in PHYSICAL_JOINT_NAMES:
        raise ValueError(f'unknown joint {joint_name!r}: expected one of '
                         f'{", ".join(PHYSICAL_JOINT_NAMES)}')
    index = PHYSICAL_JOINT_NAMES.index(joint_name)
    return role_permutation(base).index(index) + 1


def joint_of_role(role: int, base: str) -> str:
    """Physical joint name playing role ``role`` (1..5) for the given base gripper."""
    if role not in (1, 2, 3, 4, 5):
        raise ValueError(f'joint role must be 1..5, got {role!r}')
    return PHYSICAL_JOINT_NAMES[role_permutation(base)[role - 1]]
