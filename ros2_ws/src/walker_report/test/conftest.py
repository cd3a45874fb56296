"""Fixtures of walker_report's tests: the synthetic two-step walk as a bag, and its report."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from walker_report.core.animation import AnimationOptions
from walker_report.core.report import ReportOptions, make_report

from synthetic_walk import build_walk_bag

#: Small, quick animation frames: 2 frames per second of the walk, 160x100 pixels.
SMALL_ANIMATION = AnimationOptions(fps=2.0, max_frames=600, width=160, height=100)


@pytest.fixture(scope='session')
def walk_bag(tmp_path_factory) -> Path:
    """Write the synthetic two-step walk (every topic) once per session."""
    return build_walk_bag(tmp_path_factory.mktemp('walk') / 'bag')


@pytest.fixture(scope='session')
def report(walk_bag, tmp_path_factory):
    """Make the report of the synthetic walk once, with a small animation."""
    return make_report(walk_bag, tmp_path_factory.mktemp('report') / 'report',
                       options=ReportOptions(animation_options=SMALL_ANIMATION,
                                              settle_time=1.0))  # the synthetic walk's window
