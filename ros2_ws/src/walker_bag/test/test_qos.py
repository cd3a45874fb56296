"""Offered QoS in rosbag2's version-9 form, and the request that matches every publisher."""

import pytest
import yaml
from rosbags.rosbag2.metadata import parse_qos
from rosbags.interfaces import QosDurability, QosReliability

from walker_bag.core.errors import MetadataError, TopicConflictError
from walker_bag.core.qos import (
    INFINITE_DURATION_NS, QosProfile, qos_profiles_from_yaml, qos_profiles_to_yaml,
    subscription_policies)

ROSBAG2_KEYS = ['history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
                'liveliness', 'liveliness_lease_duration', 'avoid_ros_namespace_conventions']


def test_a_discovered_latched_publisher_is_written_as_jazzy_writes_it():
    profile = QosProfile('reliable', 'transient_local')
    node = profile.to_yaml()
    assert list(node) == ROSBAG2_KEYS
    assert node['history'] == 'unknown' and node['depth'] == 0
    assert node['reliability'] == 'reliable' and node['durability'] == 'transient_local'
    assert node['liveliness'] == 'automatic'
    infinite = {'sec': 9223372036, 'nsec': 854775807}
    assert node['deadline'] == node['lifespan'] == node['liveliness_lease_duration'] == infinite
    assert node['avoid_ros_namespace_conventions'] is False
    assert profile.latched


def test_finite_durations_split_into_seconds_and_nanoseconds():
    node = QosProfile('best_effort', 'volatile', deadline_ns=1_050_000_000).to_yaml()
    assert node['deadline'] == {'sec': 1, 'nsec': 50_000_000}


@pytest.mark.parametrize('profile', [
    QosProfile('reliable', 'transient_local'),
    QosProfile('best_effort', 'volatile', 'keep_last', 5, 50_000_000, 0, 'manual_by_topic',
               200_000_000, True),
    QosProfile('system_default', 'system_default', 'keep_all', 0),
])
def test_profiles_survive_the_yaml_text_round_trip(profile):
    text = qos_profiles_to_yaml([profile, profile])
    assert qos_profiles_from_yaml(text) == (profile, profile)
    assert isinstance(yaml.safe_load(text), list)


def test_an_empty_text_is_no_profile_as_rosbag2_reads_it():
    assert qos_profiles_from_yaml('') == ()


def test_an_independent_parser_reads_the_same_policies():
    text = qos_profiles_to_yaml([QosProfile('reliable', 'transient_local'),
                                 QosProfile('best_effort', 'volatile', deadline_ns=5)])
    first, second = parse_qos(text)
    assert first.reliability == QosReliability.RELIABLE
    assert first.durability == QosDurability.TRANSIENT_LOCAL
    assert first.deadline.sec * 10**9 + first.deadline.nsec == INFINITE_DURATION_NS
    assert second.reliability == QosReliability.BEST_EFFORT
    assert (second.deadline.sec, second.deadline.nsec) == (0, 5)


@pytest.mark.parametrize('kwargs, words', [
    ({'reliability': 'RELIABLE'}, 'reliability'),
    ({'durability': 'latched'}, 'durability'),
    ({'history': 'last'}, 'history'),
    ({'depth': -1}, 'depth'),
    ({'deadline_ns': 1.5}, 'deadline_ns'),
    ({'lifespan_ns': 2**63}, 'lifespan_ns'),
    ({'avoid_ros_namespace_conventions': 'no'}, 'avoid_ros_namespace_conventions'),
])
def test_invalid_profiles_are_refused_by_field(kwargs, words):
    values = {'reliability': 'reliable', 'durability': 'volatile', **kwargs}
    with pytest.raises(TopicConflictError, match=words):
        QosProfile(**values)


@pytest.mark.parametrize('text, words', [
    ('history: [', 'not valid YAML'),
    ('history: keep_last', 'must be a list'),
    ('- history: keep_last\n  depth: 1\n', 'needs the keys'),
    (qos_profiles_to_yaml([QosProfile('reliable', 'volatile')]).replace('reliable', 'sure'),
     'reliability'),
    (qos_profiles_to_yaml([QosProfile('reliable', 'volatile')]).replace('nsec: 854775807',
                                                                        'nsec: -1', 1),
     'non-negative'),
])
def test_malformed_profile_text_is_refused(text, words):
    with pytest.raises(MetadataError, match=words):
        qos_profiles_from_yaml(text)


LATCHED = QosProfile('reliable', 'transient_local')
RELIABLE = QosProfile('reliable', 'volatile')
SENSOR = QosProfile('best_effort', 'volatile')


@pytest.mark.parametrize('offers, expected', [
    ([LATCHED], ('reliable', 'transient_local')),
    ([LATCHED, LATCHED], ('reliable', 'transient_local')),
    ([RELIABLE], ('reliable', 'volatile')),
    ([LATCHED, RELIABLE], ('reliable', 'volatile')),
    ([SENSOR], ('best_effort', 'volatile')),
    ([RELIABLE, SENSOR], ('best_effort', 'volatile')),
    ([QosProfile('best_effort', 'transient_local')], ('best_effort', 'transient_local')),
    ([], ('reliable', 'volatile')),
])
def test_the_request_matches_every_offer(offers, expected):
    assert subscription_policies(offers) == expected
