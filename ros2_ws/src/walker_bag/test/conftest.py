"""Fixtures of walker_bag's tests; makes the test helpers beside this file importable."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from walker_bag.core.bag_reader import walker_typestore
from walker_bag.core.bag_writer import BagWriter

from walker_bag_samples import add_walk_topics, write_walk


@pytest.fixture(scope='session')
def typestore():
    return walker_typestore()


@pytest.fixture
def walk_bag(tmp_path: Path, typestore):
    """Write a closed bag of 20 messages on each walk topic; return (directory, messages)."""
    path = tmp_path / 'walk'
    with BagWriter(path, custom_data={'robot': 'walker'}) as writer:
        add_walk_topics(writer)
        written = write_walk(writer, typestore, 20)
    return path, written
