"""Shared pytest fixtures: isolated ROS 2 domains for tests that start nodes."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import settings

from ros_test_support import isolated_domain, ros_environment


# Property tests are judged by what they find, not by how fast a loaded machine runs an example:
# no per-example deadline, and the same examples on every run.
settings.register_profile('walker', deadline=None, derandomize=True)
settings.load_profile('walker')


def pytest_configure(config: pytest.Config) -> None:
    """Refuse to run where DDS discovery could leave the machine."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'


@pytest.fixture
def ros_env() -> Iterator[dict[str, str]]:
    """Environment for node processes: a domain of their own, discovery on loopback."""
    with isolated_domain() as domain:
        yield ros_environment(domain)


@pytest.fixture
def rclpy_context(ros_env: dict[str, str]) -> Iterator[object]:
    """Initialise rclpy in the test process, in the test's own domain."""
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_env['ROS_DOMAIN_ID']))
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)
