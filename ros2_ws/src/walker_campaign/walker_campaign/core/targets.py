"""Parameters addressed by a spec: a dotted name, one element of a per-joint list, a pattern.

A key is a parameter's dotted name as in the parameter file (``robot.mass.gripper``), one
element of a list parameter (``control.filter.corner[0]``: role J1's), or, for dispersions, a
pattern (``robot.drive.*.friction_torque``, ``sim.imperfections.joint_noise[*]``; shell-style,
:mod:`fnmatch`). Dispersions act on single numbers: a pattern or a list parameter named whole
stands for every number it covers. Which parameters a spec may touch is decided here:

* a **dispersion** changes the *truth*: a number the plant reads (the robot's geometry, masses,
  drives and modes, the truss, the grippers, ``sim.imperfections``), never a setting of the
  simulation itself (rates, timeouts), the timing every node shares, or the seed the campaign
  owns;
* a **sweep** changes the *model*'s settings the lab tunes: ``control.*``, ``planner.*`` and
  ``supervisor.*``, every node given the swept value; and the equipment the lab fits the robot
  with, which the model and the truth share: ``gripper.camera.*`` (the wrist cameras).
"""

from __future__ import annotations

import dataclasses
import fnmatch
import functools
import re
from collections.abc import Mapping
from typing import Any

from walker_core.parameter_schema import ParameterSpec, leaf_specs
from walker_campaign.core.errors import SpecError

__all__ = ['ParameterTarget', 'catalogue', 'TRUTH_PREFIXES', 'TUNABLE_PREFIXES',
           'truth_targets', 'tunable_target', 'IMPERFECTION_SEED']

#: What a dispersion may change: the robot, truss and grippers as they really are.
TRUTH_PREFIXES = ('robot.geometry.', 'robot.mass.', 'robot.drive.', 'robot.flexibility.',
                  'truss.', 'gripper.', 'sim.imperfections.')
#: What a sweep may change: the settings of the controllers, the planner and the supervisor,
#: and the wrist cameras the grippers carry.
TUNABLE_PREFIXES = ('control.', 'planner.', 'supervisor.', 'gripper.camera.')
#: The seed of the plant's imperfections: set by the campaign for every run.
IMPERFECTION_SEED = 'sim.imperfections.seed'
_KEY = re.compile(r'^([A-Za-z0-9_.*?]+)(?:\[(\d+|\*)\])?$')
_NUMBER_TYPES = (float, tuple[float, ...])


@functools.cache
def catalogue() -> dict[str, ParameterSpec]:
    """Every parameter of the walker's file that a spec may name, by dotted name."""
    from walker_control.core.config import ControlParameters
    from walker_core.robot_parameters import WalkerParameters
    from walker_planner.core.parameters import PlannerParameters
    from walker_sim.core.config import SimParameters
    from walker_supervisor.core.sequencer import SupervisorParameters

    specs = (leaf_specs(WalkerParameters) + leaf_specs(SimParameters, 'sim.')
             + leaf_specs(ControlParameters, 'control.')
             + leaf_specs(PlannerParameters, 'planner.')
             + leaf_specs(SupervisorParameters, 'supervisor.'))
    return {spec.name: spec for spec in specs}


@dataclasses.dataclass(frozen=True)
class ParameterTarget:
    """One parameter, or one element of a list parameter.

    Attributes
    ----------
    name : str
        The parameter's dotted name.
    element : int or None
        The element of a list parameter (``None``: the whole value).
    spec : ParameterSpec
        Its declaration (type, unit, range).
    """

    name: str
    element: int | None
    spec: ParameterSpec

    @property
    def key(self) -> str:
        """How a spec and the results name it: ``name`` or ``name[element]``."""
        return self.name if self.element is None else f'{self.name}[{self.element}]'

    def get(self, flat: Mapping[str, Any]) -> Any:
        """Its value in a flat ``{dotted name: value}`` mapping."""
        value = flat[self.name]
        return value if self.element is None else value[self.element]

    def set(self, flat: dict[str, Any], value: Any) -> None:
        """Put ``value`` into a flat mapping (a list parameter gets a new list)."""
        if self.element is None:
            flat[self.name] = list(value) if isinstance(value, (list, tuple)) else value
            return
        values = list(flat[self.name])
        values[self.element] = value
        flat[self.name] = values


def _split(key: Any, where: str) -> tuple[str, str | None]:
    match = _KEY.match(key) if isinstance(key, str) else None
    if match is None:
        raise SpecError(f'{where}: {key!r} is not a parameter key: expected a dotted name, '
                        'optionally with an element, e.g. control.filter.corner[0]')
    return match.group(1), match.group(2)


def _elements(name: str, index: str | None, nominal: Mapping[str, Any], spec: ParameterSpec,
              where: str) -> list[int | None]:
    is_list = spec.type in (tuple[float, ...], tuple[int, ...], tuple[str, ...])
    if index is None:
        return list(range(len(nominal[name]))) if is_list else [None]
    if not is_list:
        raise SpecError(f'{where}: {name} is a single value, not a list: drop [{index}]')
    count = len(nominal[name])
    if index == '*':
        return list(range(count))
    if int(index) >= count:
        raise SpecError(f'{where}: {name} has {count} elements (0..{count - 1}), not '
                        f'[{index}]')
    return [int(index)]


def truth_targets(key: Any, nominal: Mapping[str, Any], where: str) -> list[ParameterTarget]:
    """Return the numbers a dispersion key stands for (a name, an element or a pattern).

    Raises
    ------
    SpecError
        The key matches no parameter, or one the truth does not own (a setting of the model,
        of the simulation or of the timing), or one that is not a real number.
    """
    pattern, index = _split(key, where)
    specs = catalogue()
    names = sorted(n for n in specs if fnmatch.fnmatchcase(n, pattern))
    if not names:
        raise SpecError(f"{where}: {key!r} names no parameter of the walker's file")
    targets: list[ParameterTarget] = []
    for name in names:
        if not name.startswith(TRUTH_PREFIXES) or name == IMPERFECTION_SEED:
            if '*' in pattern or '?' in pattern:
                continue  # a pattern covers the truth's parameters among those it matches
            owner = ('the campaign sets it for every run' if name == IMPERFECTION_SEED else
                     "a sweep changes the model's settings" if name.startswith(
                         TUNABLE_PREFIXES) else 'it is not a property of the robot or truss')
            raise SpecError(f'{where}: {name} cannot be dispersed ({owner}); dispersions '
                            f'change the truth: {", ".join(p + "*" for p in TRUTH_PREFIXES)}')
        spec = specs[name]
        if spec.type not in _NUMBER_TYPES:
            if '*' in pattern or '?' in pattern:
                continue
            raise SpecError(f'{where}: {name} is not a real number (type '
                            f'{getattr(spec.type, "__name__", spec.type)}): it cannot be '
                            'dispersed')
        targets += [ParameterTarget(name, e, spec)
                    for e in _elements(name, index, nominal, spec, where)]
    if not targets:
        raise SpecError(f'{where}: {key!r} matches no real number the truth owns '
                        f'({", ".join(p + "*" for p in TRUTH_PREFIXES)})')
    return targets


def tunable_target(key: Any, nominal: Mapping[str, Any], where: str) -> ParameterTarget:
    """Return the one parameter (or element) a sweep key names.

    Raises
    ------
    SpecError
        The key is a pattern, names no parameter, or one that is not a setting of the
        controllers, the planner or the supervisor.
    """
    name, index = _split(key, where)
    if '*' in name or '?' in name or index == '*':
        raise SpecError(f'{where}: a sweep names one parameter (or one element), not a '
                        f'pattern: {key!r}')
    spec = catalogue().get(name)
    if spec is None:
        raise SpecError(f"{where}: {name!r} is not a parameter of the walker's file")
    if not name.startswith(TUNABLE_PREFIXES):
        tunable = ', '.join(p + '*' for p in TUNABLE_PREFIXES)
        raise SpecError(f'{where}: {name} is not a setting of the controllers, the planner, '
                        f'the supervisor or the cameras ({tunable}); the truth is dispersed, '
                        'not swept')
    element = None if index is None else _elements(name, index, nominal, spec, where)[0]
    return ParameterTarget(name, element, spec)
