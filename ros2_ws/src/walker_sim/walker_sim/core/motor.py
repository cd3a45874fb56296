"""Joint drives in plain numpy: torque saturation, refusal of non-finite commands, friction.

The drive model is separate from the simulator calls (the plant applies what this computes):

* the commanded torque of each joint is replaced by 0 when it is NaN or infinite (the drive
  refuses it; the plant reports it) and clamped to the drive's ``torque_limit``;
* joint friction is Coulomb friction with stiction (the paper: friction above 10% of the maximum
  torque). A joint moving slower than ``stiction_velocity`` is *stuck*: it stays still unless the
  net torque on it exceeds the breakaway level ``stiction_torque``; once moving, the friction
  torque is ``friction_torque`` against the motion.

The plant realises the friction torque as pybullet's joint velocity motor with target velocity 0
and its maximum force set to the level chosen here: the constraint solver then applies exactly
the torque needed to hold the joint still, if it is within the level, or the level against the
motion otherwise. This is implicit (no chatter around zero speed, no step-size limit), and it
accounts for every other torque on the joint, including the coupling through the other joints
and the flexible links, which an explicit stick/slip model could not know.

All arrays are in physical joint order (``a_yaw_joint`` ... ``b_yaw_joint``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

__all__ = ['DriveCommand', 'DriveModel']


@dataclasses.dataclass(frozen=True)
class DriveCommand:
    """Torques a drive applies for a command, and what it did to the command.

    Attributes
    ----------
    torque : ndarray, shape (5,)
        Applied torque [N*m]: the command, clamped, with refused values replaced by 0.
    saturated : ndarray of bool, shape (5,)
        The command exceeded the torque limit and was clamped.
    refused : ndarray of bool, shape (5,)
        The command was NaN or infinite and was replaced by 0.
    """

    torque: np.ndarray
    saturated: np.ndarray
    refused: np.ndarray


@dataclasses.dataclass(frozen=True)
class DriveModel:
    """The five joint drives.

    Parameters
    ----------
    torque_limit, friction_torque, stiction_torque : array_like, shape (5,)
        Per physical joint [N*m].
    stiction_velocity : float
        Joint speed [rad/s] below which a joint is stuck.
    """

    torque_limit: np.ndarray
    friction_torque: np.ndarray
    stiction_torque: np.ndarray
    stiction_velocity: float

    def __post_init__(self) -> None:
        for name in ('torque_limit', 'friction_torque', 'stiction_torque'):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (5,) or not np.all(np.isfinite(value)) or np.any(value < 0):
                raise ValueError(f'{name} must be 5 finite non-negative torques, got {value}')
            object.__setattr__(self, name, value)
        if not self.stiction_velocity > 0:
            raise ValueError(f'stiction_velocity must be positive, got {self.stiction_velocity}')
        object.__setattr__(self, '_stiction_levels', tuple(self.stiction_torque.tolist()))
        object.__setattr__(self, '_coulomb_levels', tuple(self.friction_torque.tolist()))
        object.__setattr__(self, '_limits', tuple(self.torque_limit.tolist()))
        object.__setattr__(self, '_levels', tuple(zip(self._stiction_levels,
                                                      self._coulomb_levels, strict=True)))

    @classmethod
    def from_parameters(cls, params, sim) -> 'DriveModel':
        """Build from the shared parameters and the plant's ``sim`` section.

        The drives are symmetric (yaw, pitch, vertex, pitch, yaw), so physical order and role
        order give the same arrays whichever gripper is the base.
        """
        drives = params.robot.drive
        return cls(torque_limit=drives.role_array('torque_limit'),
                   friction_torque=drives.role_array('friction_torque'),
                   stiction_torque=drives.role_array('stiction_torque'),
                   stiction_velocity=sim.stiction_velocity)

    def command(self, torque) -> DriveCommand:
        """Apply the drive's limits to a torque command.

        Parameters
        ----------
        torque : array_like, shape (5,)
            Commanded joint torques [N*m], physical order.

        Returns
        -------
        DriveCommand
            The applied torques and which commands were clamped or refused.

        Raises
        ------
        ValueError
            If the command does not have five values (nothing is applied).
        """
        raw = np.asarray(torque, dtype=float)
        if raw.shape != (5,):
            raise ValueError(f'a torque command needs 5 values ({", ".join(PHYSICAL_JOINT_NAMES)})'
                             f', got shape {raw.shape}')
        # plain floats, as np.clip compares (max first, then min): the plant asks every period
        applied, saturated, refused = [], [], []
        for value, limit in zip(raw.tolist(), self._limits, strict=True):
            bad = not math.isfinite(value)
            safe = 0.0 if bad else value
            low = safe if safe > -limit else -limit
            clamped = low if low < limit else limit
            applied.append(clamped)
            saturated.append(clamped != safe)
            refused.append(bad)
        return DriveCommand(torque=np.array(applied), saturated=np.array(saturated),
                            refused=np.array(refused))

    def friction_level(self, velocity) -> tuple[float, ...]:
        """Largest friction torque [N*m] each joint can exert during the next physics step.

        Parameters
        ----------
        velocity : sequence of 5 float
            Joint velocities [rad/s] at the start of the step.

        Returns
        -------
        tuple of 5 float
            ``stiction_torque`` for stuck joints (slower than ``stiction_velocity``), else
            ``friction_torque``. Plain floats: the plant asks every physics step.
        """
        limit = self.stiction_velocity
        return tuple([stiction if -limit < v < limit else coulomb
                      for v, (stiction, coulomb) in zip(velocity, self._levels, strict=True)])
