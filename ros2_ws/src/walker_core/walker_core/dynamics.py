"""Rigid-body inertia of the walker: the diagonal terms of paper eqs (9)-(13), corrected.

The rigid model of the paper lumps the moving masses at three points: ``m3`` at the vertex J3,
``m4`` at the tip wrist J4 and ``m5`` at the tip (gripper with its yaw drive), and adds each
motor's rotor inertia reflected through its gear, ``n_i^2 I_m``. Gravity is absent (zero g).

Misprints corrected (each shown wrong by ``test_dynamics.py`` against the independent
:func:`mass_matrix_numerical`):

* eq (9): the third term of the ``m5`` lever arm is printed ``l3 sin(th2 + th3)``; there is no
  ``l3``, the second link has length ``l2``.
* eq (10): the ``m5`` cross term is printed with ``cos(th2 + th3 + th4)``. The distance from J2
  to the tip is ``|c + l1 u|`` with ``c`` the J2-J4 chord (length ``l2 sqrt(2(1 + cos th3))``,
  direction ``th2 + th3/2``) and ``u`` the gripper direction (``th2 + th3 + th4``); the angle
  between them is ``th3/2 + th4``, so the term is ``2 l1 l2 sqrt(2(1+cos th3)) cos(th3/2 + th4)
  = 2 l1 l2 (cos th4 + cos(th3 + th4))``. The printed form is constant at alpha = 0.
  The term ``m3 l2^2`` of the vertex mass swinging about J2 is also missing.
* eq (11): the term ``m4 l2^2`` of the wrist mass swinging about J3 is missing.

Eqs (12) and (13) are right as printed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from walker_core.kinematics import WalkerKinematics

__all__ = ['RigidModel', 'role_inertia', 'diagonal_inertia', 'mass_matrix_numerical',
           'point_mass_positions']


@dataclasses.dataclass(frozen=True)
class RigidModel:
    """Parameters of the lumped rigid model.

    Attributes
    ----------
    l1, l2 : float
        Wrist offset and link length [m].
    m3, m4, m5 : float
        Point masses at J3, J4 and the tip [kg].
    gear_ratios : tuple of 5 float
        Gear ratio n_i of roles J1..J5.
    motor_inertia : float
        Rotor inertia I_m [kg*m^2].
    """

    l1: float
    l2: float
    m3: float
    m4: float
    m5: float
    gear_ratios: tuple[float, ...]
    motor_inertia: float

    @classmethod
    def from_parameters(cls, params) -> 'RigidModel':
        """Build from :class:`walker_core.robot_parameters.WalkerParameters`."""
        m3, m4, m5 = params.robot.mass.lumped
        drive = params.robot.drive
        return cls(l1=params.robot.geometry.l1, l2=params.robot.geometry.l2,
                   m3=m3, m4=m4, m5=m5, gear_ratios=tuple(drive.role_array('gear_ratio')),
                   motor_inertia=drive.motor_inertia)

    @property
    def reflected_motor_inertia(self) -> np.ndarray:
        """``n_i^2 I_m`` for roles J1..J5 [kg*m^2]."""
        return np.array([self.rotor_inertia(role) for role in (1, 2, 3, 4, 5)])

    def rotor_inertia(self, role: int) -> float:
        """``n_i^2 I_m`` of role ``role`` (1..5) [kg*m^2]."""
        ratio = float(self.gear_ratios[role - 1])
        return ratio * ratio * self.motor_inertia


def role_inertia(theta: Sequence[float], model: RigidModel, role: int) -> float:
    """Diagonal term ``I_ii`` of one role (eqs (9)-(13), corrected), in plain float arithmetic.

    The one-joint form of :func:`diagonal_inertia`, for a controller that needs its own term
    every control period: it computes that term alone, with no array.

    Parameters
    ----------
    theta : sequence of 5 float
        Joint angles J1..J5 [rad].
    model : RigidModel
        Lumped masses, lengths and drives.
    role : int
        The joint role 1..5.

    Returns
    -------
    float
        Inertia seen by joint ``role`` [kg*m^2], the others held still.

    Raises
    ------
    ValueError
        For a role outside 1..5.
    """
    l1, l2 = model.l1, model.l2
    m5 = model.m5
    if role == 1:
        # eq (9): squared distances of the masses from the yaw axis (l3 misprint -> l2)
        t2, t3, t4 = float(theta[1]), float(theta[2]), float(theta[3])
        arm3 = l2 * math.sin(t2)
        arm4 = arm3 + l2 * math.sin(t2 + t3)
        arm5 = arm4 + l1 * math.sin(t2 + t3 + t4)
        return (model.rotor_inertia(1) + model.m3 * arm3 ** 2 + model.m4 * arm4 ** 2
                + m5 * arm5 ** 2)
    if role == 2:
        # eq (10): squared distances from the J2 axis (cross term and m3 term corrected)
        t3, t4 = float(theta[2]), float(theta[3])
        chord_sq = 2.0 * l2 ** 2 * (1.0 + math.cos(t3))
        return (model.rotor_inertia(2) + model.m3 * l2 ** 2 + model.m4 * chord_sq
                + m5 * (chord_sq + l1 ** 2 + 2.0 * l1 * l2 * (math.cos(t4) + math.cos(t3 + t4))))
    if role == 3:
        # eq (11): squared distances from the J3 axis (m4 term restored)
        t4 = float(theta[3])
        return (model.rotor_inertia(3) + model.m4 * l2 ** 2
                + m5 * (l1 ** 2 + l2 ** 2 + 2.0 * l1 * l2 * math.cos(t4)))
    if role == 4:  # eq (12)
        return model.rotor_inertia(4) + m5 * l1 ** 2
    if role == 5:  # eq (13)
        return model.rotor_inertia(5)
    raise ValueError(f'joint role must be 1..5, got {role!r}')


def diagonal_inertia(theta: Sequence[float], model: RigidModel) -> np.ndarray:
    """Diagonal terms I_11..I_55 of the joint-space inertia matrix (eqs (9)-(13), corrected).

    Parameters
    ----------
    theta : sequence of 5 float
        Joint angles J1..J5 [rad].
    model : RigidModel
        Lumped masses, lengths and drives.

    Returns
    -------
    ndarray, shape (5,)
        Inertia seen by each joint [kg*m^2], the others held still.
    """
    theta = [float(value) for value in theta]
    return np.array([role_inertia(theta, model, role) for role in (1, 2, 3, 4, 5)])


def point_mass_positions(theta: Sequence[float], model: RigidModel) -> np.ndarray:
    """Positions [m] of the point masses m3, m4, m5 in the base frame, shape (3, 3)."""
    kinematics = WalkerKinematics(model.l1, model.l2)
    return kinematics.joint_positions(theta)[1:]


def mass_matrix_numerical(theta: Sequence[float], model: RigidModel,
                          step: float = 1e-6) -> np.ndarray:
    """Full 5x5 inertia matrix ``sum_k m_k J_k^T J_k + diag(n^2 I_m)``, by finite differences.

    An independent check of :func:`diagonal_inertia`: the point-mass Jacobians ``J_k`` are
    obtained by central differences of the forward kinematics, with no use of eqs (9)-(13).
    """
    theta = np.asarray(theta, dtype=float)
    masses = np.array([model.m3, model.m4, model.m5])
    jacobians = np.zeros((3, 3, 5))
    for j in range(5):
        delta = np.zeros(5)
        delta[j] = step
        plus = point_mass_positions(theta + delta, model)
        minus = point_mass_positions(theta - delta, model)
        jacobians[:, :, j] = (plus - minus) / (2.0 * step)
    matrix = np.einsum('k,kij,kil->jl', masses, jacobians, jacobians)
    return matrix + np.diag(model.reflected_motor_inertia)
