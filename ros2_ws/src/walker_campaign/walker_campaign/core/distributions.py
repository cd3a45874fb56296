"""The distributions a dispersion draws from: uniform, normal (optionally truncated), a list.

A spec writes one of::

    uniform: {low: 0.9, high: 1.3}
    normal: {mean: 1.0, std: 0.1}              # optionally low: / high: (truncated: redrawn)
    values: [0.8, 1.0, 1.2]                    # a fixed list, each value equally likely

Each draw takes a :class:`numpy.random.Generator`; the campaign gives every dispersion of every
run a generator of its own (:mod:`walker_campaign.core.plan`), so draws never depend on the
order in which runs or dispersions are evaluated.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy import stats

from walker_campaign.core.errors import SpecError

__all__ = ['Distribution', 'Uniform', 'Normal', 'Values', 'KINDS', 'distribution_from_spec']

#: The keys that name a distribution in a spec.
KINDS = ('uniform', 'normal', 'values')
#: A truncated normal whose interval holds less than this probability is refused.
_MIN_TRUNCATED_MASS = 1e-3


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SpecError(f'{where}: expected a finite number, got {value!r}')
    return float(value)


@dataclasses.dataclass(frozen=True)
class Uniform:
    """Uniform on ``[low, high]``."""

    low: float
    high: float

    def draw(self, generator: np.random.Generator) -> float:
        """One value."""
        return float(generator.uniform(self.low, self.high))

    @property
    def extremes(self) -> tuple[float, ...]:
        """The values at the ends of the support (checked against the schema at spec time)."""
        return (self.low, self.high)

    def describe(self) -> str:
        """One line for the report."""
        return f'uniform on [{self.low:g}, {self.high:g}]'


@dataclasses.dataclass(frozen=True)
class Normal:
    """Normal of ``mean`` and standard deviation ``std``, optionally truncated to ``[low, high]``.

    A truncated draw is redrawn until it falls inside (rejection), which keeps the shape of the
    normal inside the interval.
    """

    mean: float
    std: float
    low: float = -math.inf
    high: float = math.inf

    def draw(self, generator: np.random.Generator) -> float:
        """One value."""
        while True:
            value = float(generator.normal(self.mean, self.std))
            if self.low <= value <= self.high:
                return value

    @property
    def extremes(self) -> tuple[float, ...]:
        """The values checked against the schema at spec time.

        The truncation bounds, else the mean +- 4 standard deviations (1 run in 16,000 is
        beyond them).
        """
        return (max(self.low, self.mean - 4.0 * self.std),
                min(self.high, self.mean + 4.0 * self.std))

    def describe(self) -> str:
        """One line for the report."""
        text = f'normal, mean {self.mean:g}, standard deviation {self.std:g}'
        if math.isfinite(self.low) or math.isfinite(self.high):
            text += f', truncated to [{self.low:g}, {self.high:g}]'
        return text


@dataclasses.dataclass(frozen=True)
class Values:
    """A fixed list of values, each equally likely (one value: a constant)."""

    values: tuple[float, ...]

    def draw(self, generator: np.random.Generator) -> float:
        """One value."""
        if len(self.values) == 1:
            return self.values[0]
        return self.values[int(generator.integers(len(self.values)))]

    @property
    def extremes(self) -> tuple[float, ...]:
        """Every value of the list."""
        return self.values

    def describe(self) -> str:
        """One line for the report."""
        if len(self.values) == 1:
            return f'fixed at {self.values[0]:g}'
        return 'one of ' + ', '.join(f'{v:g}' for v in self.values) + ', equally likely'


Distribution = Uniform | Normal | Values


def distribution_from_spec(kind: str, body: Any, where: str) -> Distribution:
    """Build a distribution from its spec entry.

    Parameters
    ----------
    kind : str
        ``'uniform'``, ``'normal'`` or ``'values'``.
    body : mapping or list
        ``{low, high}``, ``{mean, std[, low, high]}`` or a list of numbers.
    where : str
        The field's path in the spec, for the error message.

    Raises
    ------
    SpecError
        Naming the field and what is wrong with it.
    """
    if kind == 'values':
        if isinstance(body, (str, bytes, Mapping)) or not isinstance(body, (list, tuple)) \
                or not body:
            raise SpecError(f'{where}: expected a non-empty list of numbers, got {body!r}')
        return Values(tuple(_number(v, f'{where}[{i}]') for i, v in enumerate(body)))
    fields = {'uniform': ({'low', 'high'}, set()), 'normal': ({'mean', 'std'}, {'low', 'high'})}
    if kind not in fields:
        raise SpecError(f'{where}: unknown distribution {kind!r}: expected one of '
                        f'{", ".join(KINDS)}')
    required, optional = fields[kind]
    if not isinstance(body, Mapping):
        raise SpecError(f'{where}: expected a mapping with {", ".join(sorted(required))}, '
                        f'got {body!r}')
    missing = sorted(required - set(body))
    unknown = sorted(set(body) - required - optional)
    if missing or unknown:
        raise SpecError(f'{where}: ' + '; '.join(
            ([f'missing {", ".join(missing)}'] if missing else [])
            + ([f'unknown {", ".join(map(str, unknown))}'] if unknown else [])))
    values = {k: _number(v, f'{where}.{k}') for k, v in body.items()}
    if kind == 'uniform':
        if not values['low'] < values['high']:
            raise SpecError(f'{where}: low ({values["low"]:g}) must be below high '
                            f'({values["high"]:g})')
        return Uniform(values['low'], values['high'])
    if not values['std'] > 0.0:
        raise SpecError(f'{where}.std: must be positive, got {values["std"]:g} (for a '
                        f'constant write values: [{values["mean"]:g}])')
    normal = Normal(values['mean'], values['std'], values.get('low', -math.inf),
                    values.get('high', math.inf))
    if not normal.low < normal.high:
        raise SpecError(f'{where}: low ({normal.low:g}) must be below high ({normal.high:g})')
    mass = (stats.norm.cdf(normal.high, normal.mean, normal.std)
            - stats.norm.cdf(normal.low, normal.mean, normal.std))
    if mass < _MIN_TRUNCATED_MASS:
        raise SpecError(f'{where}: [{normal.low:g}, {normal.high:g}] holds only {mass:.1e} of '
                        'the normal: move the mean or widen the bounds')
    return normal
