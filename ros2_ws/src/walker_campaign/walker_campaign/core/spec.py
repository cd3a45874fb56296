"""The campaign spec: a YAML file that says which walks to run, under which dispersions.

::

    extends: default_walk.yaml     # optional: start from another spec, change what differs
                                   # (walker_campaign.core.spec_file)
    name: friction_and_modes       # optional; default: the file's name
    seed: 1                        # the campaign's seed (an integer >= 0)
    runs: 200                      # dispersed walks per grid point (without sweeps: in all)
    params_file: walker.yaml       # optional nominal file, relative to the spec; default: the
                                   # installed walker.yaml
    truss_survey: survey.yaml      # optional survey file (relative to the spec) every walk
                                   # starts from
    route:
      target: n4_3                 # the node each walk goes to, from the file's sim.start
      walk_timeout: 1800           # optional [s] of wall clock per walk
      walks: 1                     # optional: 2 walks the route twice on the same truss, the
                                   # second from the survey the first wrote
    dispersions:                   # the truth against the model (the plant's file only)
      joint_friction:              # a name of your own: the column in the results
        parameters: [robot.drive.*.friction_torque, robot.drive.*.stiction_torque]
        apply: scale               # value (default) | scale (x nominal) | offset (+ nominal)
        normal: {mean: 1.0, std: 0.1}   # or uniform: {low, high}, or values: [a, b, ...]
        per_parameter: false       # true: an independent draw for each number covered
    sweeps:                        # a grid over settings the lab tunes (every node's file)
      control.coarse.acceleration_feedback[0]: [0.0, 0.25, 0.5]

Everything is checked when the spec is read, and an error names the field
(:class:`~walker_campaign.core.errors.SpecError`): unknown keys, types, distributions, keys that
name no parameter or one the section may not change, and values the walker itself refuses (each
sweep value and every grid point through the model's schema; the ends of every distribution
through the truth's); :func:`walker_campaign.core.plan.check_every_run` then checks every
run's own truth, before any walk.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any


from walker_core.parameter_schema import ParameterError
from walker_core.truss import Truss, UnknownNodeError
from walker_campaign.core.distributions import KINDS, Distribution, distribution_from_spec
from walker_campaign.core.errors import SpecError
from walker_campaign.core.parameter_sets import check_model, check_truth, load_nominal
from walker_campaign.core.spec_file import read_spec_mapping
from walker_campaign.core.survey import load_campaign_survey
from walker_campaign.core.targets import ParameterTarget, truth_targets, tunable_target

__all__ = ['APPLY_MODES', 'Dispersion', 'Sweep', 'CampaignSpec', 'load_spec', 'parse_spec',
           'applied_value', 'shipped_spec', 'find_spec', 'with_truss_survey', 'MAX_WALKS']

#: How a drawn number changes a parameter: replaces it, multiplies it, or is added to it.
APPLY_MODES = ('value', 'scale', 'offset')
_TOP_KEYS = {'name', 'seed', 'runs', 'params_file', 'truss_survey', 'route', 'dispersions',
             'sweeps'}
_ROUTE_KEYS = {'target', 'walk_timeout', 'walks'}
#: Most walks of the route in one run (``route.walks``).
MAX_WALKS = 10
_DISPERSION_KEYS = {'parameters', 'parameter', 'apply', 'per_parameter', *KINDS}
_MAX_RUNS = 1_000_000
DEFAULT_WALK_TIMEOUT = 1800.0  # [s] wall clock: a walk of the default route takes far less


def applied_value(mode: str, nominal: float, drawn: float) -> float:
    """Return the value for a draw: ``drawn``, ``nominal * drawn`` or ``nominal + drawn``."""
    if mode == 'scale':
        return float(nominal) * drawn
    if mode == 'offset':
        return float(nominal) + drawn
    return drawn


@dataclasses.dataclass(frozen=True)
class Dispersion:
    """One dispersion: a distribution, how its draws apply, and the numbers they apply to.

    Attributes
    ----------
    name : str
        The dispersion's name (the results' column ``draw.<name>``).
    targets : tuple of ParameterTarget
        The numbers of the truth it changes.
    apply : str
        ``'value'``, ``'scale'`` or ``'offset'``.
    distribution : Distribution
        What it draws from.
    per_parameter : bool
        One independent draw per target (else one draw for all: a common factor).
    """

    name: str
    targets: tuple[ParameterTarget, ...]
    apply: str
    distribution: Distribution
    per_parameter: bool

    @property
    def columns(self) -> tuple[str, ...]:
        """Names of its drawn values in the results: ``name``, or ``name:key`` per target."""
        if self.per_parameter and len(self.targets) > 1:
            return tuple(f'{self.name}:{t.key}' for t in self.targets)
        return (self.name,)

    def describe(self) -> str:
        """One line for the report."""
        how = {'value': 'the value', 'scale': 'a factor on the nominal value',
               'offset': 'an offset from the nominal value'}[self.apply]
        keys = ', '.join(t.key for t in self.targets)
        common = ('independent draws' if self.per_parameter and len(self.targets) > 1
                  else 'one draw for all' if len(self.targets) > 1 else 'one draw')
        return f'{how}, {self.distribution.describe()} ({common}): {keys}'


@dataclasses.dataclass(frozen=True)
class Sweep:
    """One axis of the grid: a setting and the values it takes, in order."""

    target: ParameterTarget
    values: tuple[Any, ...]


@dataclasses.dataclass(frozen=True)
class CampaignSpec:
    """A checked campaign spec (see the module's docstring for the YAML).

    Attributes
    ----------
    name : str
    seed : int
    runs : int
        Dispersed walks per grid point.
    target : str
        The node each walk goes to.
    walk_timeout : float
        Wall-clock seconds a walk may take.
    dispersions : tuple of Dispersion
    sweeps : tuple of Sweep
    params_file : Path
        The nominal parameter file.
    nominal : dict
        Its flat values.
    document : dict
        Its YAML document (each run's files are written from it).
    truss_survey : dict or None
        The survey file's content every walk starts from (checked against the truss), or
        None: the walks start from the nominal truss.
    truss_survey_file : Path or None
        The file it was read from.
    walks : int
        Walks of the route in each run, on the same truss; each after the first starts from
        the survey the one before it wrote.
    """

    name: str
    seed: int
    runs: int
    target: str
    walk_timeout: float
    dispersions: tuple[Dispersion, ...]
    sweeps: tuple[Sweep, ...]
    params_file: Path
    nominal: dict[str, Any] = dataclasses.field(repr=False)
    document: dict[str, Any] = dataclasses.field(repr=False)
    truss_survey: dict[str, Any] | None = dataclasses.field(default=None, repr=False)
    truss_survey_file: Path | None = None
    walks: int = 1

    @property
    def grid(self) -> list[tuple[Any, ...]]:
        """Every grid point: one value per sweep, the last sweep varying fastest."""
        return list(itertools.product(*(s.values for s in self.sweeps)))

    @property
    def point_count(self) -> int:
        """Number of grid points (1 without sweeps)."""
        return math.prod(len(s.values) for s in self.sweeps)

    @property
    def total_runs(self) -> int:
        """Walks in the campaign: ``runs`` per grid point."""
        return self.runs * self.point_count

    @property
    def draw_columns(self) -> tuple[str, ...]:
        """Every dispersion's drawn-value column, in spec order."""
        return tuple(c for d in self.dispersions for c in d.columns)

    @property
    def digest(self) -> str:
        """Fingerprint of everything that decides a run's parameters and route.

        ``runs`` excepted: more runs extend a campaign, whose results file then resumes.
        """
        content = {
            'seed': self.seed, 'target': self.target, 'nominal': self.nominal,
            'dispersions': [[d.name, [t.key for t in d.targets], d.apply,
                             repr(d.distribution), d.per_parameter] for d in self.dispersions],
            'sweeps': [[s.target.key, list(s.values)] for s in self.sweeps]}
        if self.truss_survey is not None:  # absent: the digests of specs without one stay
            content['truss_survey'] = self.truss_survey
        if self.walks != 1:
            content['walks'] = self.walks
        text = json.dumps(content, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def model_values(self, point: int) -> dict[str, Any]:
        """Return grid point ``point``'s flat model set: the nominal file with its sweeps."""
        flat = dict(self.nominal)
        for sweep, value in zip(self.sweeps, self.grid[point], strict=True):
            sweep.target.set(flat, value)
        return flat


def with_truss_survey(spec: CampaignSpec, path: str | Path) -> CampaignSpec:
    """Return ``spec`` with every walk starting from the survey file at ``path``.

    The option ``--truss-survey FILE`` (relative to the working directory): it takes the place
    of the spec's own ``truss_survey``.

    Raises
    ------
    SpecError
        The file is missing or is not a survey of the spec's truss.
    """
    path = Path(path).expanduser().resolve()
    survey = load_campaign_survey(path, spec.nominal, '--truss-survey')
    return dataclasses.replace(spec, truss_survey=survey, truss_survey_file=path)


def _shipped_dir() -> Path:
    try:
        from ament_index_python.packages import get_package_share_directory
        candidate = Path(get_package_share_directory('walker_campaign')) / 'config'
        if candidate.is_dir():
            return candidate
    except (ImportError, LookupError, ValueError):
        pass
    return Path(__file__).resolve().parents[2] / 'config'


def shipped_spec(name: str) -> Path:
    """Return the spec shipped with walker_campaign as ``config/<name>.yaml``.

    Raises
    ------
    SpecError
        No shipped spec has that name (the message lists them).
    """
    folder = _shipped_dir()
    path = folder / f'{name}.yaml'
    if not path.is_file():
        names = ', '.join(sorted(p.stem for p in folder.glob('*.yaml'))) or 'none'
        raise SpecError(f'no campaign spec file {name!r}, and no shipped spec of that name '
                        f'(shipped: {names})')
    return path


def find_spec(text: str) -> Path:
    """Return a spec file by path, or a shipped spec by name (``default_walk``)."""
    path = Path(text)
    if path.exists() or path.suffix or len(path.parts) > 1:
        return path
    return shipped_spec(text)


def load_spec(path: str | Path) -> CampaignSpec:
    """Read and check a campaign spec file.

    Raises
    ------
    SpecError
        The file cannot be read or is not a valid spec; the message names the field.
    """
    path = Path(path)
    mapping = read_spec_mapping(path, find_base=shipped_spec)
    return parse_spec(mapping, path.stem, path.resolve().parent)


def _integer(value: Any, where: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise SpecError(f'{where}: expected an integer from {low} to {high}, got {value!r}')
    return value


def _unknown(mapping: Mapping, allowed: set[str], where: str) -> None:
    unknown = sorted(str(k) for k in mapping if k not in allowed)
    if unknown:
        raise SpecError(f'{where}: unknown key{"s" if len(unknown) > 1 else ""} '
                        f'{", ".join(unknown)} (expected: {", ".join(sorted(allowed))})')


def _mapping(value: Any, where: str, required: bool = True) -> Mapping:
    if value is None and not required:
        return {}
    if not isinstance(value, Mapping):
        raise SpecError(f'{where}: expected a mapping, got {value!r}')
    return value


def parse_spec(mapping: Any, default_name: str = 'campaign',
               base_dir: str | Path = '.') -> CampaignSpec:
    """Check a spec given as a mapping (a parsed YAML document).

    Parameters
    ----------
    mapping : mapping
        The spec.
    default_name : str
        The name when the spec gives none.
    base_dir : str or Path
        Directory a relative ``params_file`` is read from.

    Raises
    ------
    SpecError
        Naming the field and the rule.
    """
    from walker_core.robot_parameters import default_parameter_file

    spec = _mapping(mapping, 'campaign spec')
    _unknown(spec, _TOP_KEYS, 'campaign spec')
    for key in ('seed', 'runs', 'route'):
        if key not in spec:
            raise SpecError(f'campaign spec: {key} is missing')
    name = spec.get('name', default_name)
    if not isinstance(name, str) or not name or not name.replace('-', '_').isidentifier():
        raise SpecError(f'name: expected letters, digits, _ or -, got {name!r}')
    seed = _integer(spec['seed'], 'seed', 0, 2**63 - 1)
    runs = _integer(spec['runs'], 'runs', 1, _MAX_RUNS)
    params_file = spec.get('params_file')
    if params_file is None:
        params_file = default_parameter_file()
    elif not isinstance(params_file, str):
        raise SpecError(f'params_file: expected a path, got {params_file!r}')
    params_file = (Path(base_dir) / Path(params_file).expanduser()).resolve()
    try:
        nominal, document = load_nominal(params_file)
        configuration = check_model(nominal)
    except ParameterError as error:
        raise SpecError(f'params_file: {error}') from None
    route = _mapping(spec['route'], 'route')
    _unknown(route, _ROUTE_KEYS, 'route')
    target = route.get('target')
    try:
        Truss.from_parameters(configuration.walker).index(target)
    except UnknownNodeError as error:
        raise SpecError(f'route.target: {error}') from None
    timeout = route.get('walk_timeout', DEFAULT_WALK_TIMEOUT)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) \
            or not 0 < timeout < math.inf:
        raise SpecError(f'route.walk_timeout: expected a positive number of seconds, got '
                        f'{timeout!r}')
    walks = _integer(route.get('walks', 1), 'route.walks', 1, MAX_WALKS)
    survey_file = spec.get('truss_survey')
    survey = None
    if survey_file is not None:
        if not isinstance(survey_file, str) or not survey_file:
            raise SpecError(f'truss_survey: expected a path, got {survey_file!r}')
        survey_file = (Path(base_dir) / Path(survey_file).expanduser()).resolve()
        survey = load_campaign_survey(survey_file, nominal)
    dispersions = tuple(
        _dispersion(key, body, nominal)
        for key, body in _mapping(spec.get('dispersions'), 'dispersions', False).items())
    sweeps = tuple(_sweep(key, values, nominal)
                   for key, values in _mapping(spec.get('sweeps'), 'sweeps', False).items())
    _check_unique(dispersions)
    result = CampaignSpec(name, seed, runs, target, float(timeout), dispersions, sweeps,
                          params_file, nominal, document, survey, survey_file, walks)
    _check_grid(result)
    _check_extremes(result)
    return result


def _dispersion(name: Any, body: Any, nominal: Mapping[str, Any]) -> Dispersion:
    where = f'dispersions.{name}'
    if not isinstance(name, str) or not name.replace('-', '_').isidentifier():
        raise SpecError(f"{where}: a dispersion's name is letters, digits, _ or -")
    body = _mapping(body, where)
    _unknown(body, _DISPERSION_KEYS, where)
    if ('parameters' in body) == ('parameter' in body):
        raise SpecError(f'{where}: give either parameter (one key) or parameters (a list)')
    keys = body['parameters'] if 'parameters' in body else [body['parameter']]
    if not isinstance(keys, list) or not keys:
        raise SpecError(f'{where}.parameters: expected a non-empty list of keys')
    targets: list[ParameterTarget] = []
    for i, key in enumerate(keys):
        targets += truth_targets(key, nominal, f'{where}.parameters[{i}]')
    seen = [t.key for t in targets]
    doubled = sorted({k for k in seen if seen.count(k) > 1})
    if doubled:
        raise SpecError(f'{where}.parameters: {", ".join(doubled)} named twice')
    apply = body.get('apply', 'value')
    if apply not in APPLY_MODES:
        raise SpecError(f'{where}.apply: expected one of {", ".join(APPLY_MODES)}, got '
                        f'{apply!r}')
    kinds = [k for k in KINDS if k in body]
    if len(kinds) != 1:
        raise SpecError(f'{where}: give exactly one distribution: {", ".join(KINDS)}')
    per_parameter = body.get('per_parameter', False)
    if not isinstance(per_parameter, bool):
        raise SpecError(f'{where}.per_parameter: expected true or false')
    distribution = distribution_from_spec(kinds[0], body[kinds[0]], f'{where}.{kinds[0]}')
    return Dispersion(name, tuple(targets), apply, distribution, per_parameter)


def _sweep(key: Any, values: Any, nominal: Mapping[str, Any]) -> Sweep:
    where = f'sweeps.{key}'
    target = tunable_target(key, nominal, where)
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, list) or not values:
        raise SpecError(f'{where}: expected a non-empty list of values, got {values!r}')
    checked = []
    for i, value in enumerate(values):
        flat = dict(nominal)
        try:
            target.set(flat, _typed(target, value))
            check_model(flat)
        except (ParameterError, TypeError, ValueError) as error:
            raise SpecError(f'{where}[{i}] = {value!r}: the walker refuses it: {error}'
                            ) from None
        checked.append(target.get(flat))
    if len(set(map(repr, checked))) != len(checked):
        raise SpecError(f'{where}: a value is listed twice')
    return Sweep(target, tuple(tuple(v) if isinstance(v, list) else v for v in checked))


def _typed(target: ParameterTarget, value: Any) -> Any:
    """Return a spec's value in the parameter's type (an integer where a float is due: float)."""
    element_type = float if target.spec.type in (float, tuple[float, ...]) else None
    if element_type is None or isinstance(value, bool):
        return value
    if target.element is None and isinstance(value, list):
        return [float(v) if isinstance(v, int) and not isinstance(v, bool) else v
                for v in value]
    return float(value) if isinstance(value, int) else value


def _check_unique(dispersions: tuple[Dispersion, ...]) -> None:
    owners: dict[str, str] = {}
    for dispersion in dispersions:
        for target in dispersion.targets:
            if target.key in owners:
                raise SpecError(f'dispersions.{dispersion.name}: {target.key} is already '
                                f'dispersed by {owners[target.key]}')
            owners[target.key] = f'dispersions.{dispersion.name}'


def _check_grid(spec: CampaignSpec) -> None:
    if len(spec.sweeps) < 2:
        return  # each single value was checked alone
    for point, values in enumerate(spec.grid):
        try:
            check_model(spec.model_values(point))
        except ParameterError as error:
            setting = ', '.join(f'{s.target.key} = {v!r}'
                                for s, v in zip(spec.sweeps, values, strict=True))
            raise SpecError(f'sweeps: the grid point {setting} is refused by the walker: '
                            f'{error}') from None


def _check_extremes(spec: CampaignSpec) -> None:
    """Each dispersion at each end of its distribution, the others nominal, on every point."""
    for dispersion in spec.dispersions:
        for extreme in dispersion.distribution.extremes:
            for point in range(spec.point_count):
                flat = spec.model_values(point)
                for target in dispersion.targets:
                    target.set(flat, applied_value(dispersion.apply, target.get(flat), extreme))
                try:
                    check_truth(flat)
                except ParameterError as error:
                    raise SpecError(
                        f'dispersions.{dispersion.name}: at {extreme:g} ({dispersion.apply}) '
                        f'the plant refuses the truth: {error}') from None
