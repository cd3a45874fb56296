"""The truth's errors against the model: truss nodes off their places, joint sensors that err.

The controllers, the planner and the supervisor work on the model (the nominal parameter file);
a plant given other values is the *truth* differing from it. Most such differences are plain
parameters of the plant (friction, masses, modes, tolerances); the two here have no nominal
counterpart in the model and are off by default (``sim.imperfections.*``, all zero; the wrist
cameras' mount errors are here too, drawn by :mod:`walker_sim.core.camera_truth`):

* **node placement**: each truss node (its hole, mouth and axis) sits off the place the model
  gives it by an independent normal error of ``node_placement`` [m] standard deviation along x,
  y and z (the hole axis stays +z). The supervisor aims at the nominal places; the plant's
  holes, its start stance and its screw-in seats are where the nodes really are.
* **joint sensors**: each joint's position reading is off by a constant ``joint_offset``
  [rad] and a white noise of ``joint_noise`` [rad] standard deviation, drawn once per plant
  step (and at reset), so the same plant steps give the same readings. The physics, the
  speeds, the accelerations and the poses are the truth's.

Both are drawn from ``seed`` alone (node placement from stream 0, sensor noise from stream 1 of
``numpy.random.SeedSequence([seed, stream])``): the same seed gives the same truss and the same
readings, bit for bit. With every value zero nothing is drawn and the plant is exactly the
plant without this module.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_core.parameter_schema import ParameterError, parameter

__all__ = ['Imperfections', 'NodePlacement', 'JointSensors', 'PLACEMENT_STREAM',
           'SENSOR_STREAM']

#: Sub-streams of ``SeedSequence([seed, stream])``: node placement and sensor noise are
#: independent, and a change of one never moves the other.
PLACEMENT_STREAM = 0
SENSOR_STREAM = 1
_JOINTS = 5


@dataclasses.dataclass(frozen=True)
class Imperfections:
    """The truth's errors against the model (``sim.imperfections.*``); all zero: none."""

    node_placement: float = parameter(
        "standard deviation of each truss node's placement error along x, y and z", 'm', 0.0,
        0.05,
        source='chosen: none; a campaign disperses it')
    joint_offset: tuple[float, ...] = parameter(
        "constant error of each joint's position reading, physical joint order", 'rad',
        -0.1, 0.1, source='chosen: none; a campaign disperses it')
    joint_noise: tuple[float, ...] = parameter(
        "standard deviation of the white noise on each joint's position reading, every step",
        'rad', 0.0, 0.05,
        source='chosen: none; a campaign disperses it')
    camera_mount_position: float = parameter(
        "standard deviation of each wrist camera's mount error along each optical axis", 'm',
        0.0, 0.05, source='chosen: none; a campaign disperses it')
    camera_mount_angle: float = parameter(
        "standard deviation of each wrist camera's mount error about each optical axis", 'rad',
        0.0, 0.2, source='chosen: none; a campaign disperses it')
    seed: int = parameter('seed of the node placement errors, the sensor noise and the cameras',
                          '', 0, 2**32 - 1, source='chosen; a campaign sets it for each run')

    def __post_init__(self) -> None:
        for name in ('joint_offset', 'joint_noise'):
            if len(getattr(self, name)) != _JOINTS:
                raise ParameterError(f'sim.imperfections.{name} needs {_JOINTS} values (one '
                                     f'per joint), got {len(getattr(self, name))}')


def _generator(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), stream]))


class NodePlacement:
    """Where each truss node really is, against the model's grid.

    Parameters
    ----------
    node_names : sequence of str
        Every node of the truss, in :attr:`walker_core.truss.Truss.node_names` order (the
        order the errors are drawn in).
    standard_deviation : float
        Of each node's error along x, y and z [m]; 0 places every node exactly.
    seed : int
        Seed of the errors (stream :data:`PLACEMENT_STREAM`).
    """

    def __init__(self, node_names, standard_deviation: float, seed: int) -> None:
        names = list(node_names)
        self._errors: dict[str, tuple[float, float, float]] = {}
        if standard_deviation > 0.0:
            drawn = standard_deviation * _generator(seed, PLACEMENT_STREAM).standard_normal(
                (len(names), 3))
            self._errors = {name: tuple(float(v) for v in drawn[i])
                            for i, name in enumerate(names)}

    @property
    def errors(self) -> dict[str, tuple[float, float, float]]:
        """Node name -> its placement error (x, y, z) [m]; empty when every node is placed."""
        return self._errors

    def offset(self, node: str) -> np.ndarray:
        """Placement error [m] of a node (x, y, z in the truss frame); zeros when placed."""
        return np.array(self._errors.get(node, (0.0, 0.0, 0.0)))


class JointSensors:
    """The joints' position readings: the true angle, a constant offset and white noise.

    Parameters
    ----------
    offset, noise : array_like, shape (5,)
        Constant error [rad] and noise standard deviation [rad] of each joint, physical order.
    seed : int
        Seed of the noise (stream :data:`SENSOR_STREAM`); :meth:`restart` starts it over.
    """

    def __init__(self, offset, noise, seed: int) -> None:
        self._offset = np.asarray(offset, dtype=float)
        self._noise = np.asarray(noise, dtype=float)
        self._seed = int(seed)
        self._exact = not (self._offset.any() or self._noise.any())
        self._noisy = bool(self._noise.any())
        self._generator = _generator(self._seed, SENSOR_STREAM)
        self._reading_error = self._offset.copy()

    @property
    def exact(self) -> bool:
        """True when the readings are the true angles (no offset, no noise)."""
        return self._exact

    def restart(self) -> None:
        """Start the noise over from the seed (a reset plant repeats its readings)."""
        self._generator = _generator(self._seed, SENSOR_STREAM)

    def sample(self) -> None:
        """Draw the reading error of the coming readings (once per plant step)."""
        if self._noisy:
            self._reading_error = self._offset + self._noise * self._generator.standard_normal(
                _JOINTS)

    def read(self, position) -> np.ndarray:
        """Return the reading [rad] of true joint angles ``position`` (shape (5,))."""
        position = np.array(position, dtype=float)
        return position if self._exact else position + self._reading_error
