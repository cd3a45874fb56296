"""Fixtures of walker_campaign's tests: specs written on the fly."""

import sys
from pathlib import Path

import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

from campaign_samples import SMALL_SPEC
from walker_campaign.core.spec import load_spec


@pytest.fixture
def write_spec(tmp_path):
    """Write a spec mapping to a file and load it (``load=False``: the path only)."""
    def write(mapping, name='test_campaign', load=True):
        path = tmp_path / f'{name}.yaml'
        path.write_text(yaml.safe_dump(mapping, sort_keys=False))
        return load_spec(path) if load else path
    return write


@pytest.fixture
def small_spec(write_spec):
    """Two dispersions (one per joint), a 2 x 2 sweep, 3 runs per point."""
    return write_spec(SMALL_SPEC)
