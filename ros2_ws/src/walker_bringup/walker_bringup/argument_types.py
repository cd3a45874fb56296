"""The types of run_all.py's options: each refuses a bad value with a message naming it."""

from __future__ import annotations

import argparse
import math
import re

import yaml

__all__ = ['priority', 'port', 'non_negative_int', 'non_negative_float', 'positive_count',
           'parameter_assignment']


def priority(text: str) -> int:
    """Return a SCHED_FIFO priority 1..99 (argparse refuses anything else)."""
    try:
        priority = int(text)
    except ValueError:
        priority = 0
    if not 1 <= priority <= 99:
        raise argparse.ArgumentTypeError(f'expected a SCHED_FIFO priority 1..99, got {text!r}')
    return priority


def port(text: str) -> int:
    """Return a TCP port 0..65535 (0: any free one)."""
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f'expected a TCP port 0..65535 (0: any free one), got '
                                         f'{text!r}')
    return port


def non_negative_int(text: str) -> int:
    """Return a whole number >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f'expected a whole number >= 0, got {text!r}')
    return value


def non_negative_float(text: str) -> float:
    """Return a finite number of seconds >= 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f'expected a number of seconds >= 0, got {text!r}')
    return value


def positive_count(text: str) -> int:
    """Return a whole number >= 1 (of walkers)."""
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise argparse.ArgumentTypeError(f'expected a positive number of walkers, got {text!r}')
    return count


def parameter_assignment(text: str) -> tuple[str, str]:
    """Return ``(name, value)`` of ``NAME:=VALUE``, as ``ros2 run``'s ``-p`` takes it.

    The value is kept as typed (the graph's nodes get it as ``-p NAME:=VALUE``) and must be
    YAML (``true``, ``0.002``, ``[0.4, 0.3, 1.0]``, ``sim_time``); the parameter files' rules
    check the name and the value.
    """
    match = re.fullmatch(r'([A-Za-z_][A-Za-z0-9_.]*(?:\[\d+\])?):=(.+)', text.strip())
    if match is None:
        raise argparse.ArgumentTypeError(
            f'expected NAME:=VALUE (e.g. gripper.camera.enabled:=true), got {text!r}')
    try:
        yaml.safe_load(match.group(2))
    except yaml.YAMLError:
        raise argparse.ArgumentTypeError(f'{match.group(1)}: the value {match.group(2)!r} is not '
                                         'YAML') from None
    return match.group(1), match.group(2).strip()
