"""The parameter file read once into every typed section the headless loop needs.

The same file, the same sections and the same validation as the nodes (each node reads its
sections with :func:`walker_runtime.node_parameters.declare_section`): the ``/**`` section of a
``ros__parameters`` YAML file, with any ``-p``-style overrides on top.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from walker_control.core.config import ControllerSettings
from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import WalkerParameters, default_parameter_file
from walker_planner.core.parameters import PREFIX as PLANNER_PREFIX
from walker_planner.core.parameters import PlannerParameters
from walker_sim.core.config import SimParameters, check_against_walker
from walker_supervisor.core.parameters import (
    SupervisorParameters, check_with_gripper, check_with_planner)
from walker_viz.core.parameters import VIZ_PREFIX, VizParameters

__all__ = ['Sections', 'load_sections']


@dataclasses.dataclass(frozen=True)
class Sections:
    """Every section of the parameter file the headless loop uses, validated.

    Attributes
    ----------
    path : Path
        The parameter file.
    walker : WalkerParameters
        Robot, truss, gripper and timing (every node's).
    sim : SimParameters
        ``sim.*`` (the plant's).
    control : ControllerSettings
        The joint controllers' (stability check included).
    planner : PlannerParameters
        ``planner.*``.
    supervisor : SupervisorParameters
        ``supervisor.*``.
    viz : VizParameters
        ``viz.*`` (the TF and markers of the bag).
    plant : tuple of (WalkerParameters, SimParameters)
        The plant's robot and ``sim.*``: from a parameter file of the plant's own (the robot
        as it really is, where the rest works on the model: a campaign's run), or the same
        as ``walker`` and ``sim``.
    """

    path: Path
    walker: WalkerParameters
    sim: SimParameters
    control: ControllerSettings
    planner: PlannerParameters
    supervisor: SupervisorParameters
    viz: VizParameters
    plant: tuple[WalkerParameters, SimParameters] | None = None

    def __post_init__(self) -> None:
        if self.plant is None:
            object.__setattr__(self, 'plant', (self.walker, self.sim))


def load_sections(path: str | Path | None = None,
                  overrides: Mapping[str, Any] | None = None,
                  plant_path: str | Path | None = None) -> Sections:
    """Read and validate every section of a parameter file (default: the installed one).

    ``overrides`` maps dotted parameter names to values, as ``-p name:=value`` would.
    ``plant_path`` is a parameter file of the plant's own (``run_all.py
    --plant-params-file``), read and checked the same way; its robot and ``sim.*`` go to the
    plant alone.

    Raises
    ------
    ParameterError
        Naming the file's missing or invalid parameter, or a rule between sections broken.
    """
    path = Path(path or default_parameter_file())
    flat = {**load_parameter_file(path), **dict(overrides or {})}
    walker = WalkerParameters.from_flat(flat)
    sim = section_from_flat(SimParameters, flat, 'sim.')
    check_against_walker(sim, walker)
    supervisor = section_from_flat(SupervisorParameters, flat, 'supervisor.')
    planner = section_from_flat(PlannerParameters, flat, PLANNER_PREFIX)
    check_with_gripper(supervisor, walker.gripper)
    check_with_planner(supervisor, planner.stream.start_tolerance)
    plant = None
    if plant_path is not None:  # the plant's sections alone: the others' rules are the model's
        truth = {**load_parameter_file(Path(plant_path)), **dict(overrides or {})}
        plant_sim = section_from_flat(SimParameters, truth, 'sim.')
        plant = (WalkerParameters.from_flat(truth), plant_sim)
        check_against_walker(plant_sim, plant[0])
    return Sections(path, walker, sim, ControllerSettings.from_flat(flat),
                    planner, supervisor,
                    section_from_flat(VizParameters, flat, VIZ_PREFIX), plant)
