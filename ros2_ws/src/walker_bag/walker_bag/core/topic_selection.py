"""Which topics a recorder records: names and glob patterns, resolved in the robot's namespace.

Each entry of the selection is a topic name or a glob pattern (``*`` matches any characters,
``/`` included; ``?`` one character). Relative entries are resolved in the recorder's namespace,
as ROS resolves topic names: with the namespace ``/walker``, ``joint_states`` means
``/walker/joint_states`` and ``*`` every topic under ``/walker``; absolute entries (``/clock``)
are taken as they are. A pattern never matches a hidden topic (a name with a token starting with
``_``, such as the ``_action/feedback`` topics of actions), as ``ros2 bag record`` skips them
unless asked; naming a hidden topic exactly records it.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence

from walker_bag.core.errors import TopicNameError

__all__ = ['TopicSelection', 'is_hidden_topic']

_TOKEN = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*$')
_WILDCARDS = ('*', '?')


def is_hidden_topic(name: str) -> bool:
    """Tell whether a token of the name starts with ``_`` (ROS's hidden topics)."""
    return any(token.startswith('_') for token in name.split('/') if token)


def _check_name(entry: str, resolved: str) -> None:
    plain = resolved.replace('*', 'x').replace('?', 'x')
    tokens = plain.split('/')[1:]
    if not tokens or not all(_TOKEN.match(t) for t in tokens) or '__' in plain:
        raise TopicNameError(
            f'{entry!r} is not a valid topic name or pattern: use tokens of letters, digits '
            f'and _ separated by /, not starting with a digit, with * or ? as wildcards')


def _resolve(entry: str, namespace: str) -> str:
    if entry.startswith('/'):
        return entry
    return namespace.rstrip('/') + '/' + entry


class TopicSelection:
    """A set of topic names and glob patterns.

    Parameters
    ----------
    entries : sequence of str
        Names and patterns, relative (resolved in ``namespace``) or absolute.
    namespace : str
        The recorder's namespace, e.g. ``/walker``.

    Raises
    ------
    TopicNameError
        If the selection is empty, or an entry or the namespace is not a valid name (``~``
        private names are refused too: a recorder has no topics of its own).
    """

    def __init__(self, entries: Sequence[str], namespace: str = '/') -> None:
        if isinstance(entries, str):
            raise TopicNameError('topics must be a list of names or patterns, not a string')
        if not entries:
            raise TopicNameError('the topic selection is empty: nothing would be recorded; '
                                 "use ['*'] for every topic of the namespace")
        if not isinstance(namespace, str) or not namespace.startswith('/'):
            raise TopicNameError(f'namespace {namespace!r} must start with /')
        if namespace != '/':
            _check_name(namespace, namespace)
        resolved = []
        for entry in entries:
            if not isinstance(entry, str) or not entry:
                raise TopicNameError(f'topic entry {entry!r} must be a non-empty string')
            name = _resolve(entry, namespace)
            _check_name(entry, name)
            resolved.append(name)
        self._namespace = namespace
        self._names = tuple(dict.fromkeys(n for n in resolved if not self._is_pattern(n)))
        self._patterns = tuple(dict.fromkeys(n for n in resolved if self._is_pattern(n)))

    @staticmethod
    def _is_pattern(name: str) -> bool:
        return any(w in name for w in _WILDCARDS)

    @property
    def names(self) -> tuple[str, ...]:
        """The exact topic names, resolved."""
        return self._names

    @property
    def patterns(self) -> tuple[str, ...]:
        """The glob patterns, resolved."""
        return self._patterns

    def matches(self, topic: str) -> bool:
        """Tell whether the (fully qualified) topic is selected."""
        if topic in self._names:
            return True
        if is_hidden_topic(topic):
            return False
        return any(fnmatch.fnmatchcase(topic, pattern) for pattern in self._patterns)

    def __repr__(self) -> str:
        return f'TopicSelection({list(self._names + self._patterns)!r})'
