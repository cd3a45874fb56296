"""The DDS transport of a graph whose nodes may be killed and started again.

Fast DDS carries data between processes of one machine over shared memory by default. A process
killed with SIGKILL leaves its shared-memory ports behind; a node started again in its place
gets the same participant id, so the same ports, and has been seen deaf over them for minutes
(its service discovered and matched, no request delivered). The profile installed with this
package (``config/fastdds_udp_loopback.xml``) has every node's readers reached over UDP on
127.0.0.1 instead, where the kernel closes a dead process's sockets. Discovery stays as
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` makes it.

``FASTDDS_BUILTIN_TRANSPORTS=UDPv4`` does not do this: under the LOCALHOST discovery range
rmw_fastrtps sets its own transports and the variable is ignored.

A graph's transport is chosen here, once (:func:`graph_environment`): ``udp`` (the default of
``run_all.py``, its graph and ``--serve``, and of the fault graphs) or ``shm`` (the rmw
default, the environment left as it is). A graph whose environment names peers on other hosts
(``ROS_STATIC_PEERS``, a ground station) runs on ``shm`` unless told otherwise
(:func:`default_transport`): readers reached on 127.0.0.1 alone are out of those peers' reach,
so ``udp`` is refused there. ``benchmarks/transport_benchmark.py`` measured both
(docs/reliability.md): a reader whose shared-memory port was removed while it lived stays deaf
to a restarted writer whatever its subscriptions do, and UDP costs less than a tenth of a
millisecond on the 500 Hz ``joint_states`` path.
"""

from __future__ import annotations

from pathlib import Path

from walker_bringup.core.host_link import STATIC_PEERS_VARIABLE

__all__ = ['PROFILES_VARIABLE', 'STATIC_PEERS_VARIABLE', 'TRANSPORTS', 'DEFAULT_TRANSPORT',
           'default_transport', 'udp_loopback_profile', 'udp_loopback_environment',
           'graph_environment']

#: The environment variable naming Fast DDS's XML profiles file (Fast DDS 2.x, ROS 2 Jazzy).
PROFILES_VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'
_PROFILE_NAME = 'fastdds_udp_loopback.xml'
#: The transports a graph may run on: UDP on loopback, or the rmw default (shared memory).
TRANSPORTS = ('udp', 'shm')
#: What a graph of ``run_all.py`` runs on unless told otherwise (no peers on other hosts).
DEFAULT_TRANSPORT = 'udp'


def default_transport(env: dict[str, str]) -> str:
    """Return the transport of a graph started in ``env`` when none is asked for.

    :data:`DEFAULT_TRANSPORT`, or ``'shm'`` (the rmw default: readers reached on every
    interface) when ``env`` names peers on other hosts in ``ROS_STATIC_PEERS``.
    """
    return 'shm' if env.get(STATIC_PEERS_VARIABLE, '').strip() else DEFAULT_TRANSPORT


def udp_loopback_profile() -> Path:
    """Return the installed path of the UDP-on-loopback participant profile."""
    from ament_index_python.packages import get_package_share_directory

    path = Path(get_package_share_directory('walker_bringup')) / 'config' / _PROFILE_NAME
    if not path.is_file():
        raise FileNotFoundError(f'the Fast DDS profile {path} is not installed')
    return path


def udp_loopback_environment(env: dict[str, str]) -> dict[str, str]:
    """Return ``env`` with the UDP-on-loopback profile selected (a new dict; ``env`` is kept).

    Refused when ``env`` already names another profiles file: one would silently replace the
    other.
    """
    profile = str(udp_loopback_profile())
    chosen = env.get(PROFILES_VARIABLE)
    if chosen and chosen != profile:
        raise ValueError(f'{PROFILES_VARIABLE} is already {chosen!r}; the UDP-on-loopback '
                         f'profile {profile!r} would replace it')
    return {**env, PROFILES_VARIABLE: profile}


def graph_environment(env: dict[str, str], transport: str = DEFAULT_TRANSPORT) -> dict[str, str]:
    """Return ``env`` for the nodes of a graph on ``transport`` (a new dict; ``env`` is kept).

    Parameters
    ----------
    env : dict
        The environment the nodes would otherwise get.
    transport : str
        ``'udp'``: the UDP-on-loopback profile selected (:func:`udp_loopback_environment`);
        ``'shm'``: the rmw default, ``env`` unchanged (a profile it names is kept), but for
        the UDP-on-loopback profile, which is removed.

    Raises
    ------
    ValueError
        An unknown transport, or ``'udp'`` with another profiles file already named.
    """
    if transport == 'udp':
        peers = env.get(STATIC_PEERS_VARIABLE, '').strip()
        if peers:
            raise ValueError(f'{STATIC_PEERS_VARIABLE} names peers on other hosts ({peers}); UDP '
                             "on loopback keeps the graph's readers on 127.0.0.1, out of their "
                             'reach')
        return udp_loopback_environment(env)
    if transport == 'shm':
        if env.get(PROFILES_VARIABLE) == str(udp_loopback_profile()):
            # inherited from a graph on UDP started before: it would keep this one's readers
            # on 127.0.0.1, out of reach of peers on other hosts
            return {k: v for k, v in env.items() if k != PROFILES_VARIABLE}
        return dict(env)
    raise ValueError(f'unknown transport {transport!r}: one of {", ".join(TRANSPORTS)}')
