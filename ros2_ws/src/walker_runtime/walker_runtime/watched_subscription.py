"""A subscription watched for silence on the steady clock, which makes itself anew.

A subscription can stop receiving while its publisher lives on (Fast DDS's shared-memory
transport after a process of the graph was killed and started again, or frozen and resumed);
waiting does not heal it, a new subscription is matched anew
(:class:`~walker_runtime.core.resubscription.Resubscription` says when). Every node that
watches an input stream holds it as a :class:`WatchedSubscription` and calls :meth:`check` from
a steady-clock timer (its watchdog's): silent for ``after`` seconds, the subscription is
destroyed and created again, with the same callback and QoS, once per ``after`` while the
silence lasts, and the node's log says so.

A silence counts only while the stream's peers are alive
(:func:`~walker_runtime.core.resubscription.peers_alive`): the topic has a publisher in the ROS
graph, and the caller's ``counts`` (a clock that runs past the newest message, peers heard
from otherwise) holds. What counts as heard the caller may say too: ``last_heard`` (the
stream's newest message as the node's own watchdog judges it; by default, the last time the
callback ran). The renewal itself is
:class:`Renewal`'s, which holds nothing of a subscription: a publisher that must be made anew
when its commands have no effect is :class:`RenewablePublisher`; a subscription read on demand
through a :class:`~walker_runtime.spinning.TopicSampler` is :class:`SampledSubscription`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node

from walker_runtime.core.resubscription import Resubscription, peers_alive

__all__ = ['Renewal', 'WatchedSubscription', 'SampledSubscription', 'RenewablePublisher']


class Renewal:
    """A middleware entity made anew when the stream it serves has been silent for long.

    Subclasses create and destroy the entity (:meth:`_create`, :meth:`_destroy`); this class
    decides when, on the steady clock, and logs it.

    Parameters
    ----------
    logger : rclpy logger
        Where the renewal is reported (a warning).
    label : str
        What the log line names (the topic).
    after : float or None
        [s] steady time: silence before the first renewal, and between renewals; None: made
        anew only when its owner calls :meth:`renew` (:meth:`check` never does).
    last_heard : callable, optional
        Returns the steady time [s] of the stream's newest message, or None when it has not
        been heard from; by default the time :meth:`heard` was last called.
    counts : callable, optional
        A silence counts only while ``counts()`` is True (and the entity has peers).
    count_from_start : bool
        Count a silence from the entity's creation when nothing has been heard yet (for a
        stream ``counts`` already knows to be running); by default a stream never heard from
        is left alone (its publisher may not have started).
    steady_now : callable, optional
        Steady time [s] (default: :func:`time.monotonic`).
    """

    def __init__(self, logger, label: str, after: float | None, *,
                 last_heard: Callable[[], float | None] | None = None,
                 counts: Callable[[], bool] | None = None, count_from_start: bool = False,
                 steady_now: Callable[[], float] = time.monotonic) -> None:
        self._rule = Resubscription(after) if after is not None else None
        self._logger = logger
        self.label = label
        self._last_heard_source = last_heard
        self._counts = counts
        self._count_from_start = count_from_start
        self._steady_now = steady_now
        self._heard: float | None = None
        self._created = steady_now()
        self._retired = False  # destroyed for good: never made anew

    @property
    def after(self) -> float | None:
        """[s] steady time of silence before a renewal (settable: a parameter changed)."""
        return self._rule.after if self._rule is not None else None

    @after.setter
    def after(self, value: float) -> None:
        if self._rule is None:
            self._rule = Resubscription(value)
        else:
            self._rule.after = value

    @property
    def renewals(self) -> int:
        """How many times the entity was made anew for a silence."""
        return self._rule.attempts if self._rule is not None else 0

    def heard(self, now: float | None = None) -> None:
        """Note a message of the stream, at steady time ``now`` [s] (default: now)."""
        self._heard = self._steady_now() if now is None else now

    @property
    def last_heard(self) -> float | None:
        """[s] steady time of the stream's newest message; None when never heard from."""
        heard = self._heard if self._last_heard_source is None else self._last_heard_source()
        if heard is None and self._count_from_start:
            return self._created
        return heard

    def check(self, now: float | None = None) -> bool:
        """Make the entity anew if its stream has been silent for long; say whether it was.

        Only while its peers are alive (:meth:`peers` in the graph, and ``counts``): the
        silence of a peer that is gone or stopped is left to the node's watchdog.

        Parameters
        ----------
        now : float, optional
            [s] steady time now (default: the ``steady_now`` given).
        """
        if self._rule is None or self._retired:
            return False
        now = self._steady_now() if now is None else now
        last_heard = self.last_heard
        if not self._rule.silent(now, last_heard):
            return False
        peers = self.peers()
        alive = peers_alive(peers, self._counts is None or bool(self._counts()))
        if not self._rule.due(now, last_heard, alive):
            return False
        self.renew()
        self._logger.warning(
            f'{self.label}: silent for {now - last_heard:.1f} s while {peers} '
            f'{self._peer_kind} in the graph, {self._entity_kind} made anew (a restarted or '
            'resumed peer is matched again)')
        return True

    #: what the log line calls the entity and its peers
    _entity_kind = 'subscription'
    _peer_kind = 'publisher(s)'

    def peers(self) -> int:
        """Count the entity's peers in the ROS graph now (a subscription's: its publishers)."""
        raise NotImplementedError

    def renew(self) -> None:
        """Destroy the entity and create it again, now (no silence needed, nothing logged).

        Nothing after :meth:`destroy`.
        """
        if self._retired:
            return
        self._destroy()
        self._create()

    def destroy(self) -> None:
        """Destroy the entity for good: :meth:`check` and :meth:`renew` make it anew no more."""
        self._retired = True
        self._destroy()

    def _create(self) -> None:
        raise NotImplementedError

    def _destroy(self) -> None:
        raise NotImplementedError


class WatchedSubscription(Renewal):
    """A subscription that makes itself anew when its stream falls silent (module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        Creates the subscription (and, unless ``logger`` is given, logs the renewals).
    message_type : type
        The message type.
    topic : str
        The topic, as for ``Node.create_subscription``.
    callback : callable
        Called with each message; the message counts as heard first.
    qos : rclpy.qos.QoSProfile
        The subscription's QoS.
    after : float
        [s] steady time of silence before a renewal (see :class:`Renewal`).
    event_callbacks : rclpy.event_handler.SubscriptionEventCallbacks, optional
        Default: none at all, not even rclpy's default warnings: destroying a subscription that
        has event handlers while the events executor spins is an open crash report
        (ros2/rclpy#1644). A publisher of incompatible QoS is still warned of on its side.
    raw : bool
        Hand the callback the serialized message.
    logger : rclpy logger, optional
        Where renewals are logged (default: ``node``'s).
    **watch
        ``last_heard``, ``counts``, ``count_from_start``, ``steady_now``, ``label`` of
        :class:`Renewal` (``label`` defaults to the topic).
    """

    def __init__(self, node: Node, message_type: type, topic: str,
                 callback: Callable[[Any], None], qos, *, after: float,
                 event_callbacks: SubscriptionEventCallbacks | None = None, raw: bool = False,
                 logger=None, label: str | None = None, **watch) -> None:
        super().__init__(logger if logger is not None else node.get_logger(),
                         label or topic, after, **watch)
        self._node = node
        self._message_type = message_type
        self._topic = topic
        self._callback = callback
        self._qos = qos
        self._event_callbacks = event_callbacks
        self._raw = raw
        self.subscription = None
        self._create()

    def _on_message(self, message) -> None:
        self.heard()
        self._callback(message)

    def peers(self) -> int:
        """Count the publishers of the subscription's topic (as remapped) in the ROS graph."""
        return self._node.count_publishers(self.subscription.topic_name)

    def _create(self) -> None:
        events = self._event_callbacks if self._event_callbacks is not None \
            else SubscriptionEventCallbacks(use_default_callbacks=False)
        self.subscription = self._node.create_subscription(
            self._message_type, self._topic, self._on_message, self._qos,
            event_callbacks=events, raw=self._raw)

    def _destroy(self) -> None:
        if self.subscription is not None:
            self._node.destroy_subscription(self.subscription)
            self.subscription = None


class SampledSubscription(Renewal):
    """A :class:`~walker_runtime.spinning.TopicSampler` subscription watched for silence.

    For a stream a node takes in batches (:meth:`take`) instead of a callback per message:
    what a take returns counts as heard. The subscription lives on the sampler's helper node,
    which no executor spins, so it may be made anew whatever executor spins the node itself
    (the events executor registers a node's entities only once).

    Parameters
    ----------
    sampler : walker_runtime.spinning.TopicSampler
        Holds the subscription.
    message_type : type
        The message type.
    topic : str
        The topic, relative to the sampler's namespace.
    qos : rclpy.qos.QoSProfile
        The subscription's QoS (its depth: the messages kept between two takes).
    after : float
        [s] steady time of silence before a renewal (see :class:`Renewal`).
    logger : rclpy logger
        Where renewals are logged.
    **watch
        ``last_heard``, ``counts``, ``count_from_start``, ``steady_now``, ``label`` of
        :class:`Renewal` (``label`` defaults to the topic).
    """

    def __init__(self, sampler, message_type: type, topic: str, qos, *, after: float, logger,
                 label: str | None = None, **watch) -> None:
        super().__init__(logger, label or topic, after, **watch)
        self._sampler = sampler
        self._message_type = message_type
        self._topic = topic
        self._qos = qos
        self.subscription = None
        self._create()

    def take(self) -> list:
        """Every message received since the last take, oldest first (heard when any)."""
        taken = self._sampler.take(self.subscription)
        if taken:
            self.heard()
        return taken

    def peers(self) -> int:
        """Count the publishers of the subscription's topic in the ROS graph now."""
        return self._sampler.node.count_publishers(self.subscription.topic_name)

    def _create(self) -> None:
        self.subscription = self._sampler.subscribe(self._message_type, self._topic, self._qos)

    def _destroy(self) -> None:
        if self.subscription is not None:
            self._sampler.unsubscribe(self.subscription)
            self.subscription = None


class RenewablePublisher(Renewal):
    """A publisher its owner makes anew when its commands have no effect.

    The supervisor's ``control_mode`` publisher: a controller still in HOLD after the mode was
    repeated several times is not hearing it (``walker_supervisor.core.health.ModeRepetition``
    decides), and a new publisher is matched anew with every subscriber. The owner calls
    :meth:`renew`; a silence-driven :meth:`check` is there too, with ``last_heard`` saying
    when the commands last had their effect.

    Parameters
    ----------
    node : rclpy.node.Node
        Creates the publisher (and, unless ``logger`` is given, logs).
    message_type : type
        The message type.
    topic : str
        The topic.
    qos : rclpy.qos.QoSProfile
        The publisher's QoS.
    after : float, optional
        [s] steady time before a silence-driven renewal (see :class:`Renewal`); by default
        none: made anew by its owner only.
    logger : rclpy logger, optional
        Where renewals are logged (default: ``node``'s).
    **watch
        As for :class:`Renewal`.
    """

    _entity_kind = 'publisher'
    _peer_kind = 'subscriber(s)'

    def __init__(self, node: Node, message_type: type, topic: str, qos, *,
                 after: float | None = None, logger=None, label: str | None = None,
                 **watch) -> None:
        super().__init__(logger if logger is not None else node.get_logger(),
                         label or topic, after, **watch)
        self._node = node
        self._message_type = message_type
        self._topic = topic
        self._qos = qos
        self.publisher = None
        self._create()

    def publish(self, message) -> None:
        """Publish ``message`` on the current publisher."""
        self.publisher.publish(message)

    def peers(self) -> int:
        """Count the subscribers of the publisher's topic in the ROS graph now."""
        return self._node.count_subscribers(self.publisher.topic_name)

    def _create(self) -> None:
        self.publisher = self._node.create_publisher(self._message_type, self._topic, self._qos)

    def _destroy(self) -> None:
        if self.publisher is not None:
            self._node.destroy_publisher(self.publisher)
            self.publisher = None
