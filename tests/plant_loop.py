"""The plant core and the five controller cores in one process, at the control rate, no ROS.

What the node graph does over DDS in sim-time mode, without the messages: every control period
the five :class:`~walker_control.core.joint_controller.JointController` cores read the plant's
state (position, velocity, acceleration of their joint, the five positions for the inertia)
and their setpoint, and the plant core applies their efforts for one period. Deterministic and
a few times faster than real time, so the tests that need the closed loop on the flexible plant
stay short.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_control.core.config import ControllerSettings
from walker_control.core.inputs import Setpoint
from walker_control.core.joint_controller import JointController, Measurement
from walker_control.core.modes import Mode
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, other_gripper
from walker_sim.core.plant import PlantState, WalkerPlant

__all__ = ['Record', 'ClosedLoop']


@dataclasses.dataclass
class Record:
    """What was measured every control period: time [s], joints [rad], tip position [m].

    ``tip`` is the true position of the tip gripper's contact point in the truss frame;
    ``fk_tip`` is where the forward kinematics of the measured joint angles puts it (from the
    base gripper's true pose), i.e. what the supervisor believes.
    """

    time: list = dataclasses.field(default_factory=list)
    position: list = dataclasses.field(default_factory=list)
    tip: list = dataclasses.field(default_factory=list)
    fk_tip: list = dataclasses.field(default_factory=list)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Return time (N,), position (N, 5), tip (N, 3) and fk_tip (N, 3) as arrays."""
        return (np.array(self.time), np.array(self.position), np.array(self.tip),
                np.array(self.fk_tip))


class ClosedLoop:
    """Five joint controllers closing their loops on the plant core (gripper a as base).

    Parameters
    ----------
    plant : WalkerPlant
        The plant, reset to where the experiment starts.
    settings : ControllerSettings
        The controllers' parameters.
    """

    def __init__(self, plant: WalkerPlant, settings: ControllerSettings) -> None:
        self.plant = plant
        self.settings = settings
        self.period = settings.sample_time
        self.controllers = [JointController(settings, name, 'a') for name in PHYSICAL_JOINT_NAMES]
        self.state: PlantState = plant.state()
        self.record = Record()

    def command(self, mode: Mode) -> None:
        """Put all five controllers in ``mode`` (gripper a as base)."""
        for controller in self.controllers:
            controller.command(mode, 'a')

    def step(self, setpoints) -> PlantState:
        """Run one control period: each controller's effort, then the plant for one period.

        Parameters
        ----------
        setpoints : sequence of Setpoint or None
            One per physical joint (None: no new setpoint).
        """
        state = self.state
        positions = tuple(float(v) for v in state.position)
        efforts = np.empty(5)
        for index, (controller, setpoint) in enumerate(zip(self.controllers, setpoints,
                                                           strict=True)):
            measurement = Measurement(positions[index], float(state.velocity[index]),
                                      float(state.acceleration[index]), positions)
            efforts[index] = controller.update(measurement, setpoint, self.period).effort
        self.state = self.plant.step(efforts, self.period)
        self._log()
        return self.state

    def follow(self, positions, velocities, accelerations) -> None:
        """Stream a sampled joint trajectory (arrays (N, 5), physical order), one per period."""
        for q, v, a in zip(positions, velocities, accelerations, strict=True):
            self.step([Setpoint(float(q[j]), float(v[j]), float(a[j])) for j in range(5)])

    def hold_setpoint(self, position, duration: float) -> None:
        """Keep streaming ``position`` at rest for ``duration`` seconds (as the planner does)."""
        setpoints = [Setpoint(float(p), 0.0, 0.0) for p in position]
        for _ in range(round(duration / self.period)):
            self.step(setpoints)

    def tip_and_fk(self, state: PlantState) -> tuple[np.ndarray, np.ndarray]:
        """Return the true tip and the forward kinematics of the joints [m], truss frame.

        The base gripper is screwed in, so its true pose carries the kinematics' base frame;
        the tip is the gripper at the chain's other end (while both are attached the plant's
        ``state.tip`` is the gripper the next step moves, which may be that base).
        """
        base = state.poses[state.base].matrix()
        fk = base @ self.plant.kinematics.forward_transform(state.position)
        return state.poses[other_gripper(state.base)].position.copy(), fk[:3, 3].copy()

    def _log(self) -> None:
        tip, fk_tip = self.tip_and_fk(self.state)
        self.record.time.append(self.state.time)
        self.record.position.append(self.state.position.copy())
        self.record.tip.append(tip)
        self.record.fk_tip.append(fk_tip)
