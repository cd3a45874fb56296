"""Each run's parameters, from the campaign's seed and the run's index alone.

Run ``k`` of a campaign with ``P`` grid points is replicate ``k // P`` at grid point ``k % P``:
the points take turns, so every point has results early, and more runs extend a campaign
without moving the runs it has. Every draw of a replicate comes from
``numpy.random.SeedSequence([seed, replicate], spawn_key=(stream,))``, one stream per dispersion
(a CRC-32 of its name) and one for the plant's imperfection seed, so:

* any run can be planned (and re-run) alone, bit for bit, from the spec and its index;
* the grid points of one replicate see the same truth (common random numbers): differences
  between points are the settings', not the draws';
* adding or removing a dispersion does not change the others' draws.
"""

from __future__ import annotations

import dataclasses
import zlib
from typing import Any

import numpy as np

from walker_core.parameter_schema import ParameterError
from walker_campaign.core.errors import SpecError
from walker_campaign.core.parameter_sets import check_truth
from walker_campaign.core.spec import CampaignSpec, applied_value
from walker_campaign.core.targets import IMPERFECTION_SEED

__all__ = ['RunPlan', 'plan_run', 'run_location', 'check_every_run']


@dataclasses.dataclass(frozen=True)
class RunPlan:
    """What one run is.

    Attributes
    ----------
    index, replicate, point : int
        The run's index in the campaign, its replicate and its grid point.
    sweep : dict
        Sweep key -> the value at this grid point.
    draws : dict
        Dispersion column (:attr:`~walker_campaign.core.spec.Dispersion.columns`) -> the value
        drawn (before it is applied as a value, a factor or an offset).
    imperfection_seed : int
        The plant's ``sim.imperfections.seed`` (node placement, sensor noise).
    model_values : dict
        Flat values of the model's file that differ from the nominal file (the sweep's).
    truth_values : dict
        Flat values of the plant's file that differ from the nominal file (the sweep's, the
        dispersed ones, the imperfection seed).
    """

    index: int
    replicate: int
    point: int
    sweep: dict[str, Any]
    draws: dict[str, float]
    imperfection_seed: int
    model_values: dict[str, Any]
    truth_values: dict[str, Any]


def _stream(name: str) -> int:
    return zlib.crc32(name.encode())


def _sequence(spec: CampaignSpec, replicate: int, name: str) -> np.random.SeedSequence:
    return np.random.SeedSequence([spec.seed, replicate], spawn_key=(_stream(name),))


def run_location(spec: CampaignSpec, index: int) -> tuple[int, int]:
    """``(replicate, grid point)`` of run ``index``.

    Raises
    ------
    SpecError
        The index is not a run of the campaign.
    """
    if isinstance(index, bool) or not isinstance(index, int) \
            or not 0 <= index < spec.total_runs:
        raise SpecError(f'run index {index!r} is not a run of campaign {spec.name} '
                        f'(0..{spec.total_runs - 1})')
    return divmod(index, spec.point_count)


def plan_run(spec: CampaignSpec, index: int) -> RunPlan:
    """Plan run ``index``: its grid point, its draws and its two sets of values."""
    replicate, point = run_location(spec, index)
    model = spec.model_values(point)
    changed_model = {s.target.name: model[s.target.name] for s in spec.sweeps}
    truth = dict(model)
    draws: dict[str, float] = {}
    for dispersion in spec.dispersions:
        generator = np.random.default_rng(_sequence(spec, replicate, dispersion.name))
        if dispersion.per_parameter:
            drawn = [dispersion.distribution.draw(generator) for _ in dispersion.targets]
        else:
            drawn = [dispersion.distribution.draw(generator)] * len(dispersion.targets)
        for target, value in zip(dispersion.targets, drawn, strict=True):
            target.set(truth, applied_value(dispersion.apply, target.get(truth), value))
        for column, value in zip(dispersion.columns, drawn, strict=False):
            draws[column] = value
    seed = int(_sequence(spec, replicate, IMPERFECTION_SEED).generate_state(1, np.uint32)[0])
    truth[IMPERFECTION_SEED] = seed
    changed_truth = {name: value for name, value in truth.items()
                     if name not in spec.nominal or value != spec.nominal[name]
                     or name in changed_model}
    sweep = {s.target.key: v for s, v in zip(spec.sweeps, spec.grid[point], strict=True)}
    return RunPlan(index, replicate, point, sweep, draws, seed, changed_model, changed_truth)


def check_every_run(spec: CampaignSpec) -> None:
    """Check every run's truth through the plant's schema, before any walk.

    Raises
    ------
    SpecError
        Naming the first run whose drawn truth the plant refuses, its draws and the rule.
    """
    for index in range(spec.total_runs):
        plan = plan_run(spec, index)
        truth = {**spec.nominal, **plan.truth_values}
        try:
            check_truth(truth)
        except ParameterError as error:
            drawn = ', '.join(f'{k} = {v:g}' for k, v in plan.draws.items())
            raise SpecError(f'run {index} (replicate {plan.replicate}): the plant refuses the '
                            f'drawn truth ({drawn}): {error}') from None
