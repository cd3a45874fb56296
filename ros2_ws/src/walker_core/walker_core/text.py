"""Numbers and choices in the walker's messages: what an operator reads, not Python's repr.

Every refusal, log line and answer that shows a value formats it here, so that the same value
reads the same everywhere: a numpy scalar as the number it is (``nan``, not
``np.float64(nan)``), no negative zero (``-0.0 mm`` is ``0.0 mm``), and an unknown value of a
closed set with the set it should come from, said once.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping

__all__ = ['number', 'value_text', 'millimetres', 'unknown_choice']


def _plain(value: float, spec: str) -> str:
    text = format(float(value), spec)
    if text.lstrip('+-').strip('0.') == '' and text.startswith('-'):
        text = ('+' if '+' in spec else '') + text[1:]  # rounded to zero: no sign of it
    return text


def number(value: float, spec: str = 'g') -> str:
    """Format a real number (``spec``): numpy scalars plain, no negative zero."""
    return _plain(value, spec)


def value_text(value: object, spec: str = 'g') -> str:
    """Show a value as a message does: numbers by :func:`number`, anything else by repr.

    Sequences of numbers (a numpy array, a list) are shown as ``[a, b, c]``.
    """
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return number(value, spec)
    if hasattr(value, 'tolist'):
        value = value.tolist()
    if isinstance(value, (list, tuple)) and all(
            isinstance(v, numbers.Real) and not isinstance(v, bool) for v in value):
        return '[' + ', '.join(number(v, spec) for v in value) + ']'
    return repr(value)


def millimetres(metres: float | Iterable[float], digits: int = 1, signed: bool = False) -> str:
    """Show a length in m (or several, comma separated) in millimetres, without a unit.

    ``signed`` shows ``+`` on positive values (offsets); a value that rounds to zero is shown
    as ``0.0`` (or ``+0.0``), never ``-0.0``.
    """
    spec = ('+' if signed else '') + f'.{digits}f'
    if isinstance(metres, numbers.Real):
        return _plain(float(metres) * 1e3, spec)
    return ', '.join(_plain(float(v) * 1e3, spec) for v in metres)


def unknown_choice(what: str, value: object, choices: Mapping[str, object]) -> str:
    """Say ``unknown <what> <value>: expected A (1) or B (2)``, the choices by name and value."""
    named = [f'{name} ({value_text(code)})' if code != name else name
             for name, code in choices.items()]
    expected = named[0] if len(named) == 1 else ', '.join(named[:-1]) + ' or ' + named[-1]
    return f'unknown {what} {value_text(value)}: expected {expected}'
