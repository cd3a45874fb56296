"""Digital low-pass filter of the joint controllers (paper section 3, Figure 3).

The paper filters the command of joints 1-3 against the vibration of the flexible links: joint 1
(mode near 18 rad/s) with a higher order and a lower corner than joints 2-3 (modes near
80 rad/s); joints 4-5 are not filtered. Order and corner come from the parameter file.

Three designs are offered, all discretised at the control rate with the bilinear transform,
pre-warped so that the digital filter has its analog counterpart's gain at the corner:

``'bessel'`` (the parameter file's)
    Maximally flat group delay: the pass band is delayed almost uniformly, so a filtered
    motion keeps its shape and arrives with little overshoot and a short tail. Gain -3 dB at
    the corner (``norm='mag'``). At 5 rad/s and 4th order it attenuates joint 1's 18 rad/s
    mode as much as the critically damped filter at 8 rad/s (-31 dB), and a filtered 90 deg
    sweep comes within 1 mm of its end in half the time (0.6 s against 1.2 s).
``'butterworth'``
    Maximally flat pass band and the steepest roll-off an all-pole filter of the given order
    has: for the same attenuation of the structural mode it allows the highest corner, hence
    the least phase lag in the control band, but its step response overshoots. Gain -3 dB at
    the corner.
``'critical'``
    ``n`` real poles at the corner, ``F(s) = (wf / (s + wf))^n``: the filter of the paper's
    eq (14) (n = 2). No overshoot of its step response, but it droops early (-6 dB at the
    corner for n = 2) and lags more for the same attenuation. Used to reproduce eq (14).

Order 0 is a pass-through (joints 4-5). The filter runs second-order sections in transposed
direct form II (as :func:`scipy.signal.sosfilt`), one sample (or several of a held input) per
:meth:`LowPassFilter.update`.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import signal

__all__ = ['FILTER_KINDS', 'FilterDesignError', 'design_lowpass_sos', 'LowPassFilter']

FILTER_KINDS = ('butterworth', 'critical', 'bessel')
_MAX_ORDER = 8


class FilterDesignError(ValueError):
    """A filter that cannot be built: bad order, corner or sample time."""


def design_lowpass_sos(order: int, corner: float, sample_time: float,
                       kind: str = 'butterworth') -> np.ndarray:
    """Design a digital low-pass filter as second-order sections.

    Parameters
    ----------
    order : int
        Filter order, 0 (pass-through) to 8.
    corner : float
        Corner frequency [rad/s]: the -3 dB frequency of a Butterworth or Bessel filter, the
        pole frequency ``wf`` of a critically damped one. Ignored for order 0.
    sample_time : float
        Control period [s]; the corner must lie below the Nyquist frequency ``pi / T``.
    kind : {'butterworth', 'critical', 'bessel'}
        Filter family (see the module notes).

    Returns
    -------
    ndarray, shape (n_sections, 6)
        ``[b0, b1, b2, 1, a1, a2]`` rows, DC gain exactly 1. Empty for order 0.

    Raises
    ------
    FilterDesignError
        For an order outside 0..8, a non-positive or non-finite corner or sample time, a corner
        at or above Nyquist, or an unknown kind.
    """
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) \
            or not 0 <= order <= _MAX_ORDER:
        raise FilterDesignError(f'filter order must be an integer 0..{_MAX_ORDER}, got {order!r}')
    if not (isinstance(sample_time, (int, float)) and math.isfinite(sample_time)
            and sample_time > 0.0):
        raise FilterDesignError(f'sample time must be a positive number of seconds, '
                                f'got {sample_time!r}')
    if kind not in FILTER_KINDS:
        raise FilterDesignError(f'filter kind must be one of {FILTER_KINDS}, got {kind!r}')
    if order == 0:
        return np.zeros((0, 6))
    nyquist = math.pi / sample_time
    if not (math.isfinite(corner) and 0.0 < corner < nyquist):
        raise FilterDesignError(
            f'filter corner {corner!r} rad/s must be positive and below the Nyquist frequency '
            f'{nyquist:.1f} rad/s of the {sample_time * 1e3:g} ms sample time')
    return _designed(int(order), float(corner), float(sample_time), kind)[0].copy()


@functools.lru_cache(maxsize=64)
def _designed(order: int, corner: float, sample_time: float, kind: str
              ) -> tuple[np.ndarray, tuple, np.ndarray]:
    """Return the sections of a valid design, their rows as floats, and their unit state.

    Designed once per design: scipy takes milliseconds for what the controllers rebuild at
    every restart of a reference shaper (a mode change).
    """
    fs = 1.0 / sample_time
    if kind == 'butterworth':
        sos = signal.butter(order, corner / (2.0 * math.pi), btype='low', output='sos', fs=fs)
    elif kind == 'bessel':
        sos = signal.bessel(order, corner / (2.0 * math.pi), btype='low', output='sos', fs=fs,
                            norm='mag')
    else:
        warped = 2.0 * fs * math.tan(corner * sample_time / 2.0)  # pre-warp the pole frequency
        poles = np.full(order, -warped)
        z, p, k = signal.bilinear_zpk([], poles, warped ** order, fs)
        sos = signal.zpk2sos(z, p, k)
    # Make the DC gain exactly 1 (rounding leaves ~1e-15): a held position must not drift.
    dc = np.prod(sos[:, :3].sum(axis=1) / sos[:, 3:].sum(axis=1))
    sos = sos.copy()
    sos[0, :3] /= dc
    sos.setflags(write=False)
    rows = tuple((float(b0), float(b1), float(b2), float(a1), float(a2))
                 for b0, b1, b2, _, a1, a2 in sos)
    unit_state = signal.sosfilt_zi(sos)
    unit_state.setflags(write=False)
    return sos, rows, unit_state


class LowPassFilter:
    """A stateful discrete low-pass filter, one sample at a time.

    Parameters
    ----------
    order, corner, sample_time, kind
        As :func:`design_lowpass_sos`.

    Notes
    -----
    :meth:`reset_to` sets the internal state to the steady state of a constant input, so that
    this input then passes through with no transient: the controller uses it for a bumpless
    start and when a role change brings in a different filter.
    """

    def __init__(self, order: int, corner: float, sample_time: float,
                 kind: str = 'butterworth') -> None:
        self.order = int(order)
        self.corner = float(corner)
        self.sample_time = float(sample_time)
        self.kind = kind
        self.sos = design_lowpass_sos(order, corner, sample_time, kind)
        if len(self.sos):
            _, self._coefficients, self._unit_state = _designed(
                self.order, self.corner, self.sample_time, kind)
        else:
            self._coefficients, self._unit_state = (), np.zeros((0, 2))
        self._state = [[0.0, 0.0] for _ in self._coefficients]
        self._output = 0.0

    @property
    def is_passthrough(self) -> bool:
        """True for order 0 (no filtering)."""
        return self.order == 0

    @property
    def output(self) -> float:
        """Last output [same unit as the input]."""
        return self._output

    @property
    def state(self) -> np.ndarray:
        """Internal state, shape (n_sections, 2), in the layout of :func:`scipy.signal.sosfilt`."""
        return np.array(self._state, dtype=float).reshape(-1, 2)

    def same_design(self, other: 'LowPassFilter') -> bool:
        """Tell whether ``other`` has the same coefficients (then no state needs resetting)."""
        return np.array_equal(self.sos, other.sos)

    def reset_to(self, value: float = 0.0) -> None:
        """Set the state so that a constant input ``value`` passes through with no transient."""
        value = float(value)
        self._state = [[float(a) * value, float(b) * value] for a, b in self._unit_state]
        self._output = value

    def update(self, value: float, samples: int = 1) -> float:
        """Filter ``samples`` samples of the input ``value`` (held) and return the last output.

        ``samples > 1`` advances the filter over sample periods in which the input could not be
        taken (a controller that missed states), holding it as a zero-order hold would, so that
        the filter keeps its designed dynamics in time.
        """
        sections = self._coefficients
        if not sections:  # order 0: a pass-through
            if samples >= 1:
                self._output = float(value)
            return self._output
        state = self._state
        for _ in range(samples):
            x = float(value)
            for (b0, b1, b2, a1, a2), z in zip(sections, state, strict=True):
                y = b0 * x + z[0]
                z[0] = b1 * x - a1 * y + z[1]
                z[1] = b2 * x - a2 * y
                x = y
            self._output = x
        return self._output

    def frequency_response(self, frequencies: np.ndarray) -> np.ndarray:
        """Complex gain at angular frequencies [rad/s] (of the digital filter)."""
        frequencies = np.asarray(frequencies, dtype=float)
        if self.is_passthrough:
            return np.ones_like(frequencies, dtype=complex)
        _, response = signal.freqz_sos(self.sos, worN=frequencies * self.sample_time)
        return response
