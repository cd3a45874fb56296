"""A graph's domain in this process's environment: set while it runs, given back as it was."""

import os
from pathlib import Path

import pytest

from walker_bringup.domains import domain_environment, isolated_domain

_NAMES = ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_HOME', 'WALKER_TEST_EXTRA')


def test_the_domain_is_set_on_loopback_and_the_old_environment_comes_back(monkeypatch):
    monkeypatch.setenv('ROS_DOMAIN_ID', '0')
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'SUBNET')
    monkeypatch.delenv('ROS_HOME', raising=False)
    monkeypatch.delenv('WALKER_TEST_EXTRA', raising=False)
    before = {name: os.environ.get(name) for name in _NAMES}
    with isolated_domain() as domain, domain_environment(domain, Path('/tmp/home'),
                                                         WALKER_TEST_EXTRA='1'):
        assert os.environ['ROS_DOMAIN_ID'] == str(domain)
        assert os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
        assert os.environ['ROS_HOME'] == '/tmp/home'
        assert os.environ['WALKER_TEST_EXTRA'] == '1'
    assert {name: os.environ.get(name) for name in _NAMES} == before


def test_the_old_environment_comes_back_when_the_graph_fails(monkeypatch):
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    monkeypatch.delenv('ROS_HOME', raising=False)
    with pytest.raises(RuntimeError), domain_environment(3, Path('/tmp/home')):
        raise RuntimeError('the graph did not come up')
    assert os.environ['ROS_DOMAIN_ID'] == '7'
    assert 'ROS_HOME' not in os.environ
