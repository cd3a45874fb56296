"""The walker's configuration: the parameter file read once into every typed section.

:func:`load_configuration` is the one entry point for whoever runs the whole walker (the graph
of ``run_all.py``, the headless runner, campaigns, the benchmarks): it reads the file once
(:class:`walker_core.parameter_file.ParameterFile`), builds each package's section, and runs
every rule that ties sections together, here and nowhere else. A bad file is refused with a
:class:`~walker_core.parameter_schema.ParameterError` naming the parameter and the rule,
before anything starts.

The sections stay with the packages that own them, and so do the rules between sections
(each node checks its own at start and on every runtime update); this module, in the package
that may depend on all of them and that the bring-up and the headless runner both depend on,
only gathers them (docs/architecture.md, Configuration).

A plant may be given a parameter file of its own (``run_all.py --plant-params-file``, a
campaign's *truth*): the robot as it really is, where every other part works on the model.
Of that file the plant's sections alone are read (:func:`plant_sections`): the rules between
the others are the model's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from walker_bag.core.recorder_parameters import RecorderParameters
from walker_control.core.config import ControllerSettings
from walker_core.parameter_file import ParameterFile
from walker_core.robot_parameters import WalkerParameters
from walker_planner.core.parameters import PlannerParameters
from walker_sim.core.config import SimParameters
from walker_sim.core.config import check_against_walker as check_sim_against_walker
from walker_sim.core.config import plant_sections
from walker_supervisor.core.parameters import (
    SupervisorParameters, check_with_control, check_with_gripper, check_with_planner)
from walker_supervisor.core.teleop import TeleopParameters
from walker_viz.core.parameters import VizParameters

from walker_config.core.sections import configuration_sections

__all__ = ['WalkerConfiguration', 'load_configuration', 'load_plant', 'configuration_of',
           'plant_sections', 'check_cross_section_rules']


@dataclasses.dataclass(frozen=True)
class WalkerConfiguration:
    """Every section of one parameter file, each validated, and the rules between them.

    Attributes
    ----------
    path : Path
        The file read (resolved): what every node of the graph gets as ``--params-file``.
    walker : WalkerParameters
        ``robot.*``, ``truss.*``, ``gripper.*``, ``timing.*`` (every node's).
    sim : SimParameters
        ``sim.*`` (the plant's).
    controllers : ControllerSettings
        ``control.*`` with the robot and timing, stability check passed (the controllers').
    planner : PlannerParameters
        ``planner.*``.
    supervisor : SupervisorParameters
        ``supervisor.*``.
    teleop : TeleopParameters
        ``teleop.*`` (the supervisor's operator commands).
    recorder : RecorderParameters
        ``recorder.*``.
    viz : VizParameters
        ``viz.*`` (the TF and marker publisher's).
    values : mapping
        The flat values all sections were built from (the file's, then the overrides).
    plant : tuple of (WalkerParameters, SimParameters)
        The plant's robot and ``sim.*``: from a parameter file of the plant's own, or (none
        given) the same as ``walker`` and ``sim``.
    """

    path: Path
    walker: WalkerParameters
    sim: SimParameters
    controllers: ControllerSettings
    planner: PlannerParameters
    supervisor: SupervisorParameters
    teleop: TeleopParameters
    recorder: RecorderParameters
    viz: VizParameters
    values: Mapping[str, Any]
    plant: tuple[WalkerParameters, SimParameters] | None = None

    def __post_init__(self) -> None:
        if self.plant is None:
            object.__setattr__(self, 'plant', (self.walker, self.sim))


def check_cross_section_rules(configuration: WalkerConfiguration) -> None:
    """Run every rule that ties one section to another.

    Within each section its own rules ran as it was built; the controllers' stability check,
    which ties ``control.*`` to the robot and the control rate, runs as
    :class:`~walker_control.core.config.ControllerSettings` is built.

    Raises
    ------
    ParameterError
        Naming the parameters and the rule: start nodes off the truss or a physics rate that
        is not a multiple of the control rate (``sim.*``), insertion regions wider than the
        gripper's tolerance, a coarse-start tolerance the planner's stream would refuse, a
        relaxation wait shorter than the controllers' relaxation (``supervisor.*``).
    """
    check_sim_against_walker(configuration.sim, configuration.walker)
    supervisor = configuration.supervisor
    check_with_gripper(supervisor, configuration.walker.gripper)
    check_with_planner(supervisor, configuration.planner.stream.start_tolerance)
    check_with_control(supervisor, configuration.controllers.control.relaxation.duration)


def configuration_of(file: ParameterFile,
                     plant: tuple[WalkerParameters, SimParameters] | None = None
                     ) -> WalkerConfiguration:
    """Build every section of a parameter file's values and check every rule between them.

    ``plant`` is the plant's own sections (:func:`plant_sections` of its file), if it has a
    file of its own.

    Raises
    ------
    ParameterError
        Naming the parameter and the rule; nothing is half-built.
    """
    sections = {field: file.section(section, prefix)  # the one table of the file's sections
                for field, (section, prefix) in configuration_sections().items()}
    configuration = WalkerConfiguration(path=file.path, values=file.values, plant=plant,
                                        **sections)
    check_cross_section_rules(configuration)
    return configuration


def load_configuration(path: str | Path | None = None,
                       overrides: Mapping[str, Any] | None = None,
                       plant_path: str | Path | None = None) -> WalkerConfiguration:
    """Read a parameter file once into every section and check every rule between them.

    Parameters
    ----------
    path : str or Path, optional
        The ``ros__parameters`` file, naming every parameter (default: the installed
        ``walker.yaml``).
    overrides : mapping, optional
        Flat values over the file's, ``{'sim.clock_mode': 'sim_time'}`` (as ``-p`` over
        ``--params-file``); over the plant's file too.
    plant_path : str or Path, optional
        A parameter file of the plant's own (``run_all.py --plant-params-file``): its robot
        and ``sim.*`` go to the plant alone (:attr:`WalkerConfiguration.plant`).

    Raises
    ------
    ParameterError
        If a file cannot be read or parsed, or a value or rule is broken: the message names
        the parameter. Nothing is half-built.
    """
    plant = None if plant_path is None else load_plant(plant_path, overrides)
    return configuration_of(ParameterFile.read(path, overrides), plant)


def load_plant(path: str | Path | None = None, overrides: Mapping[str, Any] | None = None
               ) -> tuple[WalkerParameters, SimParameters]:
    """Read a plant's own parameter file: its robot and ``sim.*``, and the rule between them.

    What :func:`load_configuration` reads of ``plant_path`` (``run_all.py
    --plant-params-file``, a campaign's *truth*), for a caller that names the file apart.

    Raises
    ------
    ParameterError
        If the file cannot be read or parsed, or a value or the rule is broken: the message
        names the parameter.
    """
    return plant_sections(ParameterFile.read(path, overrides))
