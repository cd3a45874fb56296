"""Small pybullet helpers: a headless client, loading the walker's URDF, naming its joints.

Every call names its physics client explicitly (``physicsClientId``), so several plants can
live in one process without sharing state.
"""

from __future__ import annotations

import contextlib
import dataclasses
import tempfile
from pathlib import Path
from collections.abc import Iterator

import pybullet

__all__ = ['BodyIndex', 'direct_client', 'load_urdf_text', 'index_body', 'free_dynamics']

# Joint speed [rad/s] above which pybullet would silently clamp (its default is 100 rad/s,
# which a rotor geared 100:1 reaches at 1 rad/s of joint speed).
_MAX_JOINT_VELOCITY = 1.0e5


@contextlib.contextmanager
def direct_client() -> Iterator[int]:
    """Open a headless (DIRECT) physics client for the duration of a ``with`` block."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        yield client
    finally:
        pybullet.disconnect(physicsClientId=client)


def load_urdf_text(client: int, urdf: str, fixed_base: bool) -> int:
    """Load a URDF document (a string) and return the body id.

    The inertias are taken from the file (pybullet would otherwise derive them from collision
    shapes, which the walker does not have).
    """
    with tempfile.TemporaryDirectory(prefix='walker_urdf_') as folder:
        path = Path(folder) / 'walker.urdf'
        path.write_text(urdf)
        return pybullet.loadURDF(str(path), useFixedBase=fixed_base,
                                 flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                                 physicsClientId=client)


@dataclasses.dataclass(frozen=True)
class BodyIndex:
    """Joint and link indices of a loaded body, by name.

    Attributes
    ----------
    joints : dict
        Joint name -> joint index (which is also the index of the joint's child link).
    links : dict
        Child link name -> link index; the base link has index -1.
    movable : tuple of int
        Indices of every joint that has a degree of freedom, in index order.
    """

    joints: dict[str, int]
    links: dict[str, int]
    movable: tuple[int, ...]


def index_body(client: int, body: int) -> BodyIndex:
    """Read the joint and link names of a body."""
    joints: dict[str, int] = {}
    links: dict[str, int] = {}
    movable = []
    base_name = pybullet.getBodyInfo(body, physicsClientId=client)[0].decode()
    links[base_name] = -1
    for index in range(pybullet.getNumJoints(body, physicsClientId=client)):
        info = pybullet.getJointInfo(body, index, physicsClientId=client)
        joints[info[1].decode()] = index
        links[info[12].decode()] = index
        if info[2] != pybullet.JOINT_FIXED:
            movable.append(index)
    return BodyIndex(joints, links, tuple(movable))


def free_dynamics(client: int, body: int, index: BodyIndex) -> None:
    """Remove pybullet's default damping, velocity clamp and joint motors from a body.

    pybullet damps every body (linear and angular damping 0.04), clamps joint speeds at
    100 rad/s and drives every joint with a velocity motor; none of that is in the walker.
    """
    for link in sorted(set(index.links.values())):
        pybullet.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0,
                                jointDamping=0.0, maxJointVelocity=_MAX_JOINT_VELOCITY,
                                physicsClientId=client)
    if index.movable:
        pybullet.setJointMotorControlArray(body, list(index.movable), pybullet.VELOCITY_CONTROL,
                                           forces=[0.0] * len(index.movable),
                                           physicsClientId=client)
