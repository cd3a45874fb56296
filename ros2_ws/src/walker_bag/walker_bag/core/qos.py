"""QoS profiles as rosbag2 (Jazzy, metadata version 9) stores the publishers' offers.

A bag keeps, for every topic, the QoS profiles its publishers offered when recording started
(``offered_qos_profiles``). ``ros2 bag play`` reads them back to offer the same QoS: a topic
whose publishers all offered ``transient_local`` durability is replayed latched. Version 9 of
the metadata writes each policy as its rmw name (``reliable``, ``transient_local``, ...) and each
duration as ``{sec, nsec}``; the same YAML list, as text, goes into the MCAP channel metadata
under the key ``offered_qos_profiles``.

Discovery does not carry the publisher's history, so the profiles of remote publishers have
``history: unknown`` and ``depth: 0``, exactly as Jazzy's recorder writes them. Durations are
integer nanoseconds; ``INFINITE_DURATION_NS`` is ``RMW_DURATION_INFINITE`` (2**63 - 1 ns),
which rosbag2 writes as ``sec: 9223372036, nsec: 854775807``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

import yaml

from walker_bag.core.errors import MetadataError, TopicConflictError

__all__ = [
    'INFINITE_DURATION_NS', 'HISTORY_POLICIES', 'RELIABILITY_POLICIES', 'DURABILITY_POLICIES',
    'LIVELINESS_POLICIES', 'QosProfile', 'qos_profiles_to_yaml', 'qos_profiles_from_yaml',
    'subscription_policies',
]

#: ``RMW_DURATION_INFINITE`` in nanoseconds, as rclpy reports an unset deadline, lifespan or
#: liveliness lease of a DDS endpoint.
INFINITE_DURATION_NS = 2**63 - 1
_NS_PER_S = 1_000_000_000

#: The rmw names of each policy (``rmw_qos_*_policy_to_str``, plus rosbag2's ``unknown``).
HISTORY_POLICIES = ('system_default', 'keep_last', 'keep_all', 'unknown')
RELIABILITY_POLICIES = ('system_default', 'reliable', 'best_effort', 'unknown', 'best_available')
DURABILITY_POLICIES = ('system_default', 'transient_local', 'volatile', 'unknown',
                       'best_available')
LIVELINESS_POLICIES = ('system_default', 'automatic', 'manual_by_node', 'manual_by_topic',
                       'unknown', 'best_available')

_DURATION_FIELDS = ('deadline', 'lifespan', 'liveliness_lease_duration')


def _duration_to_yaml(nanoseconds: int) -> dict[str, int]:
    """Split nanoseconds into rosbag2's ``{sec, nsec}`` form."""
    return {'sec': nanoseconds // _NS_PER_S, 'nsec': nanoseconds % _NS_PER_S}


def _duration_from_yaml(name: str, node: Any) -> int:
    if not isinstance(node, Mapping) or set(node) != {'sec', 'nsec'}:
        raise MetadataError(f'QoS {name} must be a mapping with sec and nsec, got {node!r}')
    sec, nsec = node['sec'], node['nsec']
    if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in (sec, nsec)):
        raise MetadataError(f'QoS {name} sec and nsec must be non-negative integers: {node!r}')
    return min(sec * _NS_PER_S + nsec, INFINITE_DURATION_NS)


@dataclasses.dataclass(frozen=True)
class QosProfile:
    """One publisher's offered QoS, in rmw policy names and integer nanoseconds.

    Parameters
    ----------
    reliability : str
        One of :data:`RELIABILITY_POLICIES`.
    durability : str
        One of :data:`DURABILITY_POLICIES`; ``transient_local`` makes a topic latched.
    history : str
        One of :data:`HISTORY_POLICIES`; ``unknown`` for remote publishers (not discovered).
    depth : int
        History depth; 0 when the history is unknown.
    deadline_ns, lifespan_ns, liveliness_lease_duration_ns : int
        Durations [ns]; :data:`INFINITE_DURATION_NS` when unset.
    liveliness : str
        One of :data:`LIVELINESS_POLICIES`.
    avoid_ros_namespace_conventions : bool
        As in ``rmw_qos_profile_t``.

    Raises
    ------
    TopicConflictError
        If a policy name is not an rmw name or a number is out of range.
    """

    reliability: str
    durability: str
    history: str = 'unknown'
    depth: int = 0
    deadline_ns: int = INFINITE_DURATION_NS
    lifespan_ns: int = INFINITE_DURATION_NS
    liveliness: str = 'automatic'
    liveliness_lease_duration_ns: int = INFINITE_DURATION_NS
    avoid_ros_namespace_conventions: bool = False

    def __post_init__(self) -> None:
        for field, allowed in (('history', HISTORY_POLICIES),
                               ('reliability', RELIABILITY_POLICIES),
                               ('durability', DURABILITY_POLICIES),
                               ('liveliness', LIVELINESS_POLICIES)):
            value = getattr(self, field)
            if value not in allowed:
                raise TopicConflictError(
                    f'QoS {field} {value!r} is not one of {", ".join(allowed)}')
        for field in ('depth', 'deadline_ns', 'lifespan_ns', 'liveliness_lease_duration_ns'):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or not (
                    0 <= value <= INFINITE_DURATION_NS):
                raise TopicConflictError(
                    f'QoS {field} must be an integer in [0, 2**63 - 1], got {value!r}')
        if not isinstance(self.avoid_ros_namespace_conventions, bool):
            raise TopicConflictError('QoS avoid_ros_namespace_conventions must be a bool')

    @property
    def latched(self) -> bool:
        """True when the publisher keeps its last messages for late subscribers."""
        return self.durability == 'transient_local'

    def to_yaml(self) -> dict[str, Any]:
        """Return the profile as rosbag2 writes it (version 9), keys in rosbag2's order."""
        return {
            'history': self.history,
            'depth': self.depth,
            'reliability': self.reliability,
            'durability': self.durability,
            'deadline': _duration_to_yaml(self.deadline_ns),
            'lifespan': _duration_to_yaml(self.lifespan_ns),
            'liveliness': self.liveliness,
            'liveliness_lease_duration': _duration_to_yaml(self.liveliness_lease_duration_ns),
            'avoid_ros_namespace_conventions': self.avoid_ros_namespace_conventions,
        }

    @classmethod
    def from_yaml(cls, node: Any) -> 'QosProfile':
        """Read a version-9 profile mapping; raise :class:`MetadataError` if malformed."""
        keys = ('history', 'depth', 'reliability', 'durability', *_DURATION_FIELDS,
                'liveliness', 'avoid_ros_namespace_conventions')
        if not isinstance(node, Mapping) or any(key not in node for key in keys):
            raise MetadataError(f'a QoS profile needs the keys {", ".join(keys)}; got {node!r}')
        try:
            return cls(
                reliability=node['reliability'], durability=node['durability'],
                history=node['history'], depth=node['depth'],
                deadline_ns=_duration_from_yaml('deadline', node['deadline']),
                lifespan_ns=_duration_from_yaml('lifespan', node['lifespan']),
                liveliness=node['liveliness'],
                liveliness_lease_duration_ns=_duration_from_yaml(
                    'liveliness_lease_duration', node['liveliness_lease_duration']),
                avoid_ros_namespace_conventions=node['avoid_ros_namespace_conventions'])
        except TopicConflictError as error:
            raise MetadataError(str(error)) from None


def qos_profiles_to_yaml(profiles: Iterable[QosProfile]) -> str:
    """Return the YAML text of profiles: the MCAP channel's ``offered_qos_profiles``."""
    return yaml.safe_dump([p.to_yaml() for p in profiles], sort_keys=False,
                          default_flow_style=False)


def qos_profiles_from_yaml(text: str) -> tuple[QosProfile, ...]:
    """Parse an ``offered_qos_profiles`` text (``''`` is an empty list, as rosbag2 reads it)."""
    if text == '':
        return ()
    try:
        node = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise MetadataError(f'offered_qos_profiles is not valid YAML: {error}') from None
    if not isinstance(node, list):
        raise MetadataError(f'offered_qos_profiles must be a list, got {type(node).__name__}')
    return tuple(QosProfile.from_yaml(item) for item in node)


def subscription_policies(offers: Iterable[QosProfile]) -> tuple[str, str]:
    """Reliability and durability a recorder requests to match every offer, as rosbag2 does.

    Reliable only when every publisher offers reliable (a reliable request does not match a
    best-effort publisher); transient local only when every publisher offers it (so latched
    messages published before the recorder started are received). With no offers the request
    is rosbag2's default, reliable and volatile.

    Returns
    -------
    tuple of str
        ``(reliability, durability)`` in rmw names.
    """
    offers = list(offers)
    reliable = all(p.reliability == 'reliable' for p in offers)
    latched = bool(offers) and all(p.durability == 'transient_local' for p in offers)
    return ('reliable' if reliable else 'best_effort',
            'transient_local' if latched else 'volatile')
