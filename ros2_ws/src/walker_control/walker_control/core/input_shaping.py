"""Input shapers: a reference convolved with impulses that cancel a flexible mode's vibration.

A lightly damped mode of natural frequency ``w`` [rad/s] and damping ratio ``z``, driven by a
sequence of impulses of amplitudes ``A_i`` at times ``t_i`` (``t_1 = 0``), rings after the last
one with an amplitude that, relative to one unit impulse, is (Singer and Seering, 1990)::

    V(w, z) = exp(-z w t_N) sqrt(C^2 + S^2),
    C = sum A_i exp(z w t_i) cos(wd t_i),  S = sum A_i exp(z w t_i) sin(wd t_i),
    wd = w sqrt(1 - z^2)

A reference convolved with the impulses (the shaper) moves the mode by ``V`` times what the
unshaped reference would leave ringing. Shapers here (all with positive impulses summing to
one, so a shaped step reaches the step exactly and the shaped motion never overshoots the
reference's range):

``ZV``
    Two impulses half a damped period apart: ``V = 0`` at the design frequency only. The
    shortest; 5 % residual is reached within a few per cent of frequency error.
``ZVD``
    Three impulses over one damped period: ``V`` and ``dV/dw`` zero at the design frequency;
    ``V <= 5 %`` over about +-14 % of frequency.
``EI`` (extra-insensitive, Singhose, Seering and Singer 1996)
    Three impulses over one damped period (at the times of ZVD), their amplitudes chosen so
    that ``V`` equals the tolerance ``Vtol`` at the design frequency with a flat top there
    (``dV/dw = 0``): the residual dips to zero on both sides and stays under ``Vtol`` over a
    range about 40 % wider than ZVD's. Undamped, the amplitudes are the closed form
    ``[(1 + Vtol)/4, (1 - Vtol)/2, (1 + Vtol)/4]``.
``SI`` (specified insensitivity, Singhose et al. 1996)
    The shortest shaper keeping ``V <= Vtol`` over a stated frequency range ``[w_lo, w_hi]``
    (at any damping ratio between ``z_lo`` and ``z_hi`` of the mode): a linear programme over
    the impulse amplitudes on the control period's grid (each ``|C + iS|`` bound written as
    sixteen half-planes inside the circle of radius ``Vtol``), solved with
    :func:`scipy.optimize.linprog` for the shortest feasible duration by bisection.

:func:`convolve` combines shapers of several modes (multi-mode shaping): the impulses of one at
every impulse of the other, amplitudes multiplied; its residual at any frequency is the product
of theirs.

:class:`DiscreteShaper` runs a shaper on a reference sampled at the control period. Impulse
times off the sample grid are **split** between the two neighbouring samples in proportion to
their nearness (linear interpolation): the amplitudes still sum to one (a step reaches the step
exactly) and each impulse's time centroid is kept, so the shaped motion is delayed exactly as
the continuous shaper delays it; rounding instead would move the cancelling impulses by up to
half a period (1 ms at 500 Hz, 1 % of the 18 rad/s mode's half period), splitting smears them by
less. The SI design is on the grid already.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import math
from collections.abc import Sequence

import numpy as np
from scipy import optimize

__all__ = ['ShaperKind', 'ShaperDesignError', 'Shaper', 'residual_vibration', 'zv', 'zvd', 'ei',
           'specified_insensitivity', 'convolve', 'design_shaper', 'DiscreteShaper']


class ShaperKind(enum.Enum):
    """The shaper families (``control.shaping.kind``); NONE: the reference is not shaped."""

    NONE = 'none'
    ZV = 'zv'
    ZVD = 'zvd'
    EI = 'ei'
    SI = 'si'


class ShaperDesignError(ValueError):
    """A shaper that cannot be designed: bad frequency, damping, tolerance or range."""


@dataclasses.dataclass(frozen=True)
class Shaper:
    """Impulses: ``amplitudes`` (sum 1, each positive) at ``times`` [s] (first 0, increasing)."""

    amplitudes: tuple[float, ...]
    times: tuple[float, ...]

    @property
    def duration(self) -> float:
        """Time of the last impulse [s]: how much later a shaped motion ends."""
        return self.times[-1]

    @property
    def delay(self) -> float:
        """Time centroid of the impulses [s]: the shaped motion's mean delay."""
        return float(np.dot(self.amplitudes, self.times))

    def residual(self, frequency, damping: float) -> np.ndarray:
        """Residual vibration ``V`` at ``frequency`` [rad/s] (see :func:`residual_vibration`)."""
        return residual_vibration(self, frequency, damping)


def residual_vibration(shaper: Shaper, frequency, damping: float) -> np.ndarray:
    """Singer and Seering's ``V(w, z)``: the mode's residual amplitude per unshaped amplitude.

    Parameters
    ----------
    shaper : Shaper
    frequency : float or array
        Natural frequency ``w`` of the mode [rad/s].
    damping : float
        Damping ratio ``z`` of the mode (0 <= z < 1).
    """
    w = np.asarray(frequency, dtype=float)[..., None]
    a = np.asarray(shaper.amplitudes)
    t = np.asarray(shaper.times)
    wd = w * math.sqrt(1.0 - damping ** 2)
    decay = np.exp(-damping * w * (t[-1] - t))
    c = np.sum(a * decay * np.cos(wd * t), axis=-1)
    s = np.sum(a * decay * np.sin(wd * t), axis=-1)
    return np.hypot(c, s)


def _check_mode(frequency: float, damping: float) -> None:
    if not (isinstance(frequency, (int, float)) and math.isfinite(frequency) and frequency > 0):
        raise ShaperDesignError(f'shaper frequency must be a positive number of rad/s, '
                                f'got {frequency!r}')
    if not (isinstance(damping, (int, float)) and 0.0 <= damping < 1.0):
        raise ShaperDesignError(f'shaper damping ratio must be in [0, 1), got {damping!r}')


def _check_tolerance(tolerance: float) -> None:
    if not (isinstance(tolerance, (int, float)) and 0.0 < tolerance < 1.0):
        raise ShaperDesignError(f'shaper tolerance must be in (0, 1), got {tolerance!r}')


def _damped_period(frequency: float, damping: float) -> float:
    return 2.0 * math.pi / (frequency * math.sqrt(1.0 - damping ** 2))


def zv(frequency: float, damping: float = 0.0) -> Shaper:
    """Zero-vibration shaper: two impulses, half a damped period apart."""
    _check_mode(frequency, damping)
    k = math.exp(-damping * math.pi / math.sqrt(1.0 - damping ** 2))
    return Shaper((1.0 / (1.0 + k), k / (1.0 + k)),
                  (0.0, _damped_period(frequency, damping) / 2.0))


def zvd(frequency: float, damping: float = 0.0) -> Shaper:
    """Zero-vibration-and-derivative shaper: three impulses over one damped period."""
    _check_mode(frequency, damping)
    k = math.exp(-damping * math.pi / math.sqrt(1.0 - damping ** 2))
    norm = (1.0 + k) ** 2
    period = _damped_period(frequency, damping)
    return Shaper((1.0 / norm, 2.0 * k / norm, k * k / norm), (0.0, period / 2.0, period))


def ei(frequency: float, damping: float = 0.0, tolerance: float = 0.05) -> Shaper:
    """Extra-insensitive shaper: ``V = tolerance`` at ``frequency``, zero on both sides of it.

    Three impulses over one damped period ``T``. Undamped, the closed form: amplitudes
    ``[(1 + Vtol)/4, (1 - Vtol)/2, (1 + Vtol)/4]`` at ``0, T/2, T`` (``V`` then peaks at
    ``Vtol`` at ``frequency`` and is zero at two frequencies around it). Damped, the
    amplitudes, the middle time and the two zeros ``w1 < frequency < w2`` solve
    ``V(frequency) = Vtol`` and ``V(w1) = V(w2) = 0`` (:func:`scipy.optimize.fsolve`, started
    from the closed form); the last impulse stays at one damped period.
    """
    _check_mode(frequency, damping)
    _check_tolerance(tolerance)
    period = _damped_period(frequency, damping)
    first = (1.0 + tolerance) / 4.0
    if damping == 0.0:
        return Shaper((first, (1.0 - tolerance) / 2.0, first), (0.0, period / 2.0, period))
    # the undamped shaper's zeros: cos(w T / 2) = -(1 - Vtol) / (1 + Vtol)
    half_turn = math.acos(-(1.0 - tolerance) / (1.0 + tolerance))
    zeros = (half_turn / math.pi * frequency, (2.0 - half_turn / math.pi) * frequency)
    root = math.sqrt(1.0 - damping ** 2)

    def components(shaper: Shaper, w: float) -> tuple[float, float]:
        t = np.asarray(shaper.times)
        decay = np.exp(-damping * w * (t[-1] - t))
        a = np.asarray(shaper.amplitudes) * decay
        return float(a @ np.cos(w * root * t)), float(a @ np.sin(w * root * t))

    def shaper_of(x) -> Shaper:
        return Shaper((x[0], x[1], 1.0 - x[0] - x[1]), (0.0, x[2] * period, period))

    def equations(x):
        shaper = shaper_of(x)
        return [float(residual_vibration(shaper, frequency, damping)) - tolerance,
                *components(shaper, x[3] * frequency), *components(shaper, x[4] * frequency)]

    start = [first, (1.0 - tolerance) / 2.0, 0.5, zeros[0] / frequency, zeros[1] / frequency]
    solution, _, found, message = optimize.fsolve(equations, start, full_output=True)
    shaper = shaper_of(solution)
    if found != 1 or min(shaper.amplitudes) <= 0.0 or not 0.0 < solution[2] < 1.0 \
            or max(map(abs, equations(solution))) > 1e-9:
        raise ShaperDesignError(f'no EI shaper for {frequency:g} rad/s, damping {damping:g}, '
                                f'tolerance {tolerance:g}: {message}')
    return Shaper(tuple(map(float, shaper.amplitudes)), tuple(map(float, shaper.times)))


_SI_DIRECTIONS = 16


@functools.lru_cache(maxsize=32)
def specified_insensitivity(low: float, high: float, sample_time: float,
                            tolerance: float = 0.05, damping: tuple[float, float] = (0.0, 0.0),
                            frequencies: int = 41) -> Shaper:
    """Return the shortest shaper on the sample grid with ``V <= tolerance`` over ``[low, high]``.

    Parameters
    ----------
    low, high : float
        The frequency range the mode may lie in [rad/s] (``0 < low < high`` below Nyquist).
    sample_time : float
        Grid of the impulse times [s] (the control period).
    tolerance : float
        Largest residual vibration over the range.
    damping : (float, float)
        Range of the mode's damping ratio; the bound holds at both ends.
    frequencies : int
        Frequencies the bound is imposed at, evenly spread over the range.

    Notes
    -----
    For a duration ``D = n T``, the residual at ``(w, z)`` is ``|sum_k A_k exp(-z w (D - kT))
    exp(i wd k T)|``: linear in the amplitudes, bounded by half-planes (the circle's inscribed
    sixteen-gon). :func:`scipy.optimize.linprog` finds amplitudes (positive, summing to one)
    that minimise the largest residual; the shortest ``n`` whose residual is within the
    tolerance is found by bisection between half a period at ``high`` and 1.25 (or, failing
    that, two or four) periods at ``low``.
    """
    if not (0.0 < low < high and math.isfinite(high)):
        raise ShaperDesignError(f'SI range must satisfy 0 < low < high, got [{low!r}, {high!r}]')
    if not (math.isfinite(sample_time) and sample_time > 0 and high < math.pi / sample_time):
        raise ShaperDesignError(f'SI range top {high!r} rad/s must lie below the Nyquist '
                                f'frequency of the {sample_time!r} s sample time')
    _check_tolerance(tolerance)
    for value in damping:
        _check_mode(low, value)
    grid = np.linspace(low, high, frequencies)
    angles = 2.0 * math.pi * np.arange(_SI_DIRECTIONS) / _SI_DIRECTIONS

    def solve(n: int):
        k = np.arange(n + 1)
        rows = []
        for z in sorted(set(damping)):
            wd = grid[:, None] * math.sqrt(1.0 - z * z)
            decay = np.exp(-z * grid[:, None] * (n - k) * sample_time)
            re, im = decay * np.cos(wd * k * sample_time), decay * np.sin(wd * k * sample_time)
            for angle in angles:  # Re(e^{-i angle} (re + i im)) <= r cos(pi/16)
                rows.append(math.cos(angle) * re + math.sin(angle) * im)
        coefficients = np.vstack(rows)
        # variables: amplitudes A_0..A_n, then r; minimise r
        a_ub = np.hstack([coefficients, -np.full((len(coefficients), 1),
                                                 math.cos(math.pi / _SI_DIRECTIONS))])
        a_eq = np.hstack([np.ones((1, n + 1)), np.zeros((1, 1))])
        cost = np.zeros(n + 2)
        cost[-1] = 1.0
        result = optimize.linprog(cost, A_ub=a_ub, b_ub=np.zeros(len(a_ub)), A_eq=a_eq,
                                  b_eq=[1.0], bounds=[(0.0, None)] * (n + 2), method='highs')
        if result.status != 0:
            return math.inf, None
        return result.x[-1], result.x[:-1]

    shortest = max(1, math.floor(math.pi / high / sample_time))
    period = 2.0 * math.pi / low / sample_time
    for periods in (1.25, 2.0, 4.0):  # one period is enough for ranges up to about +-25 %
        longest = math.ceil(periods * period)
        best = solve(longest)
        if best[0] <= tolerance:
            break
    else:
        raise ShaperDesignError(f'no SI shaper within four periods keeps the residual under '
                                f'{tolerance:g} over [{low:g}, {high:g}] rad/s')
    while longest - shortest > 1:  # the residual bound falls (weakly) with the duration
        middle = (shortest + longest) // 2
        attempt = solve(middle)
        if attempt[0] <= tolerance:
            longest, best = middle, attempt
        else:
            shortest = middle
    amplitudes = np.asarray(best[1])
    amplitudes[amplitudes < 1e-9] = 0.0
    keep = np.nonzero(amplitudes)[0]
    amplitudes = amplitudes[keep] / amplitudes[keep].sum()
    times = keep * sample_time
    return Shaper(tuple(map(float, amplitudes)), tuple(map(float, times - times[0])))


def convolve(*shapers: Shaper) -> Shaper:
    """Return the shaper of several in series (multi-mode): impulses of each at every other's."""
    if not shapers:
        raise ShaperDesignError('convolve needs at least one shaper')
    amplitudes, times = np.array([1.0]), np.array([0.0])
    for shaper in shapers:
        amplitudes = np.outer(amplitudes, shaper.amplitudes).ravel()
        times = np.add.outer(times, shaper.times).ravel()
    order = np.argsort(times, kind='stable')
    merged: dict[float, float] = {}
    for time, amplitude in zip(np.round(times[order], 12), amplitudes[order], strict=True):
        merged[float(time)] = merged.get(float(time), 0.0) + float(amplitude)
    return Shaper(tuple(merged.values()), tuple(merged.keys()))


@functools.lru_cache(maxsize=64)
def design_shaper(kind: ShaperKind, frequency: float, damping: float, tolerance: float,
                  insensitivity: float, sample_time: float) -> Shaper:
    """Return the ``kind`` shaper for a mode at ``frequency`` [rad/s] (+-``insensitivity``: SI).

    SI covers ``[frequency (1 - insensitivity), frequency (1 + insensitivity)]`` at damping
    ratios from 0 to ``damping``. NONE gives the identity (one unit impulse at 0).
    """
    kind = ShaperKind(kind)
    if kind == ShaperKind.NONE:
        return Shaper((1.0,), (0.0,))
    if not (math.isfinite(sample_time) and sample_time > 0.0
            and 0.0 < frequency < math.pi / sample_time):
        raise ShaperDesignError(f'shaper frequency {frequency!r} rad/s must be positive and '
                                f'below the Nyquist frequency of the {sample_time!r} s period')
    if kind == ShaperKind.ZV:
        return zv(frequency, damping)
    if kind == ShaperKind.ZVD:
        return zvd(frequency, damping)
    if kind == ShaperKind.EI:
        return ei(frequency, damping, tolerance)
    if not 0.0 < insensitivity < 1.0:
        raise ShaperDesignError(f'SI insensitivity must be in (0, 1), got {insensitivity!r}')
    return specified_insensitivity(frequency * (1.0 - insensitivity),
                                   frequency * (1.0 + insensitivity), sample_time, tolerance,
                                   (0.0, damping))


def _grid_taps(shaper: Shaper, sample_time: float) -> np.ndarray:
    """FIR taps on the sample grid: each impulse split between its two neighbouring samples."""
    positions = np.asarray(shaper.times) / sample_time
    taps = np.zeros(int(math.floor(positions[-1] + 1e-9)) + 2)
    for amplitude, position in zip(shaper.amplitudes, positions, strict=True):
        lower = math.floor(position + 1e-9)
        fraction = max(0.0, position - lower)
        taps[lower] += amplitude * (1.0 - fraction)
        taps[lower + 1] += amplitude * fraction
    return np.trim_zeros(taps, 'b')


class DiscreteShaper:
    """A shaper running on a signal sampled at ``sample_time`` [s], one sample at a time.

    Impulses off the grid are split between neighbouring samples (module notes). Causal: the
    output at sample ``k`` is ``sum_j h_j x_(k-j)``.
    """

    def __init__(self, shaper: Shaper, sample_time: float) -> None:
        if not (math.isfinite(sample_time) and sample_time > 0.0):
            raise ShaperDesignError(f'sample time must be positive, got {sample_time!r}')
        self.shaper = shaper
        self.sample_time = float(sample_time)
        self.taps = _grid_taps(shaper, sample_time)
        self._nonzero = [(int(j), float(h)) for j, h in enumerate(self.taps) if h != 0.0]
        self._history = [0.0] * len(self.taps)  # ring buffer of inputs
        self._head = 0
        self._output = 0.0

    @property
    def duration(self) -> float:
        """Length of the taps [s]: a step's output settles this long after the step."""
        return (len(self.taps) - 1) * self.sample_time

    @property
    def output(self) -> float:
        """The last output sample."""
        return self._output

    def reset_to(self, value: float = 0.0) -> None:
        """Fill the history with ``value``: a constant input passes with no transient."""
        self._history = [float(value)] * len(self.taps)
        self._output = float(value)

    def update(self, value: float, samples: int = 1) -> float:
        """Shape ``samples`` samples of ``value`` (held) and return the last output."""
        history, size = self._history, len(self._history)
        for _ in range(samples):
            self._head = (self._head + 1) % size
            history[self._head] = float(value)
            head = self._head
            self._output = sum(h * history[(head - j) % size] for j, h in self._nonzero)
        return self._output

    def filter(self, values: Sequence[float]) -> np.ndarray:
        """Shape a whole sequence from the current state (as successive :meth:`update`)."""
        return np.array([self.update(v) for v in values])
