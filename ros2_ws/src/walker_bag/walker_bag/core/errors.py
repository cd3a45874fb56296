"""Errors of walker_bag: bad input is refused with a message naming what was wrong.

Every error is a :class:`ValueError` subclass and is raised before anything is changed: no bag
directory is created, no file is touched, no topic is half-added.
"""

from __future__ import annotations

__all__ = [
    'BagError', 'BagExistsError', 'BagPathError', 'UnknownTopicError', 'TopicConflictError',
    'BagClosedError', 'MessageDefinitionError', 'MetadataError', 'TopicNameError',
]


class BagError(ValueError):
    """Base class of every walker_bag error."""


class BagExistsError(BagError):
    """The bag directory already exists: a recording never overwrites one."""


class BagPathError(BagError):
    """The bag directory cannot be created or written, or is not a bag."""


class UnknownTopicError(BagError):
    """A message was written to, or a read asked for, a topic the bag does not hold."""


class TopicConflictError(BagError):
    """A topic was added twice with a different type, or with invalid metadata."""


class BagClosedError(BagError):
    """The bag was written to after it was closed."""


class MessageDefinitionError(BagError):
    """The definition (``.msg`` text or type hash) of a message type cannot be found."""


class MetadataError(BagError):
    """A ``metadata.yaml`` is missing, malformed, or not of a version this package reads."""


class TopicNameError(BagError):
    """A topic name or pattern is not a valid ROS 2 name."""
