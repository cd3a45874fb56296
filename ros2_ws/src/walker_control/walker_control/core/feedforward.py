"""Feed-forward from the rigid model: the diagonal inertia of eqs (9)-(13) (paper section 3).

The controller is designed on the rigid model with only the diagonal terms of the inertia
matrix (the paper found that neglecting both the coupling inertia and the centrifugal and
Coriolis terms works better than neglecting either). The inertia of the joint's *role* at the
current configuration, in role order, scales the feed-forward of the desired acceleration and
the whole normalised command (so the closed loop on the rigid model is the unit-inertia loop of
eq (14) at every configuration).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from walker_core.dynamics import RigidModel, role_inertia

__all__ = ['RigidFeedForward']


class RigidFeedForward:
    """Diagonal rigid-model inertia and feed-forward torque of one joint role.

    Parameters
    ----------
    model : RigidModel
        Lumped masses, lengths, gear ratios and motor inertia.
    """

    def __init__(self, model: RigidModel) -> None:
        self.model = model

    def inertia(self, role: int, configuration: Sequence[float]) -> float:
        """``I_ii`` of role ``role`` (1..5) [kg*m^2] at ``configuration`` (roles J1..J5, rad).

        Implements the corrected eqs (9)-(13) through
        :func:`walker_core.dynamics.role_inertia` (plain floats: the controller calls it
        every control period).
        """
        if role not in (1, 2, 3, 4, 5):
            raise ValueError(f'joint role must be 1..5, got {role!r}')
        try:
            valid = len(configuration) == 5 and all(math.isfinite(q) for q in configuration)
        except TypeError:
            valid = False
        if not valid:
            raise ValueError(f'configuration must be 5 finite angles, got {configuration!r}')
        return role_inertia(configuration, self.model, role)

    @staticmethod
    def torque(inertia: float, acceleration: float, effort: float = 0.0) -> float:
        """Feed-forward torque ``I_ii a_r + effort`` [N*m]."""
        return inertia * acceleration + effort
