"""Deaf readers reproduced on demand over real Fast DDS, and what hears again.

A reader goes deaf on this machine when the shared-memory port its participant listens on is
removed from ``/dev/shm`` while it lives (a clean-up of "leftover" Fast DDS files that took it
for a dead process's, ``fastdds shm clean``, another run's clean-up): a writer started
afterwards, a node restarted after a crash, creates the port anew and delivers into it, and
the reader listens on the old one. The port belongs to the participant, not to one
subscription: making the subscription anew (the walker's
:class:`~walker_runtime.watched_subscription.WatchedSubscription`) does not heal it. Over the
UDP-on-loopback profile (:mod:`walker_bringup.transport`) no reader listens on shared memory,
and the same fault deafens nothing. A talker killed with ``SIGKILL`` and started again is heard
again on both transports (nothing removed).

Each test runs :mod:`walker_bringup.transport_probe`'s talker and listener (500 Hz, the
best-effort ``joint_states`` and reliable command QoS) in a ROS domain of its own.
"""

import time

import pytest

from ros_test_support import isolated_domain, ros_environment
from transport_faults import ProbePair, fastdds_files, remove_shared_memory_files

from walker_bringup.processes import stale_shared_memory_files
from walker_bringup.transport import udp_loopback_environment

pytestmark = [pytest.mark.integration, pytest.mark.timeout(240)]

#: [s] wall clock for a process to start and be heard, on a loaded shared machine
START = 60.0
#: [s] the listener's subscriptions are made anew after this long a silence
RENEW_AFTER = 0.5
#: [s] a restarted talker must be heard within this of its start (its process starting and
#: being discovered; seconds on a loaded 2-core machine)
HEARD_WITHIN = 30.0
#: [s] how long a deaf listener is watched once a fresh listener hears the talker
DEAF_FOR = 5.0
#: tries of the shared-memory fault (it deafens the reader most of the time, not always)
TRIES = 3


@pytest.fixture
def shared_memory_clean_up():
    """Remove the Fast DDS files the test's killed processes left (and no one else's)."""
    before = fastdds_files()
    yield
    for path in stale_shared_memory_files(before, min_age=0.0):
        path.unlink(missing_ok=True)


def _environment(domain: int, transport: str) -> dict[str, str]:
    env = ros_environment(domain)
    return udp_loopback_environment(env) if transport == 'udp' else env


def _remove_listeners_files_restart_talker(pair: ProbePair) -> tuple[list[str], float]:
    """Remove the listener's shared-memory files, restart the talker; its restart time."""
    assert pair.hears_again(time.monotonic(), START) is not None, pair.listener.output
    removed = remove_shared_memory_files(pair.listener.process.pid)
    return removed, pair.kill_and_restart('talker')


def _deafened(env: dict[str, str]) -> str:
    """Remove a watched listener's port, restart the talker: '' if it stays deaf, else why not."""
    with ProbePair(env, renew_after=RENEW_AFTER) as pair:
        removed, restarted = _remove_listeners_files_restart_talker(pair)
        assert any(name.startswith('fastrtps_port') for name in removed), removed
        # a listener started now hears the restarted talker: it is alive and publishing
        with ProbePair(env, renew_after=0.0, talker=False) as control:
            assert control.hears_again(time.monotonic(), START) is not None, \
                control.listener.output
            renewals = pair.renewals
            watched = time.monotonic()
            heard = pair.hears_again(watched, DEAF_FOR)
            assert control.hears_again(watched, DEAF_FOR) is not None
        if heard is not None:
            return f'heard {heard:.1f} s into the watch (removed {removed})'
        # ... though its subscriptions were made anew again and again meanwhile
        assert pair.renewals >= renewals + 2, pair.listener.output
        assert time.monotonic() - restarted > DEAF_FOR
        return ''


@pytest.mark.dds_faults  # Fast DDS's fault, not the walker's: it shows on some machines only
def test_over_shared_memory_a_reader_whose_port_was_removed_stays_deaf_renewed_or_not(
        tmp_path, shared_memory_clean_up):
    """The fault deafened the reader in 7 of 8 tries on this machine: up to three are made."""
    missed = []
    for _ in range(TRIES):
        with isolated_domain() as domain:
            why = _deafened(_environment(domain, 'shm'))
        if not why:
            return
        missed.append(why)
    pytest.fail(f'the reader heard the restarted talker in every try: {missed}')


@pytest.mark.parametrize('renew_after', [0.0, RENEW_AFTER], ids=['plain', 'watched'])
def test_over_udp_loopback_the_same_fault_leaves_the_reader_hearing(
        tmp_path, shared_memory_clean_up, renew_after):
    with isolated_domain() as domain:
        with ProbePair(_environment(domain, 'udp'), renew_after=renew_after) as pair:
            _removed, restarted = _remove_listeners_files_restart_talker(pair)
            assert pair.hears_again(restarted, HEARD_WITHIN) is not None, \
                pair.listener.output


@pytest.mark.parametrize('transport', ['shm', 'udp'])
def test_a_talker_killed_and_restarted_is_heard_again(tmp_path, shared_memory_clean_up,
                                                      transport):
    with isolated_domain() as domain:
        with ProbePair(_environment(domain, transport), renew_after=0.0) as pair:
            assert pair.hears_again(time.monotonic(), START) is not None, pair.listener.output
            for _ in range(2):
                restarted = pair.kill_and_restart('talker')
                assert pair.hears_again(restarted, HEARD_WITHIN) is not None, \
                    pair.listener.output
