"""A robot host and a ground host on one machine: two network namespaces and a link (ROS-free).

The walker graph runs on a "robot" network namespace, the operator's tools (``walkerctl``, a
recorder) on a "ground" one; a veth pair joins them, one end in each, made directly inside its
namespace, so neither end nor any packet over it ever reaches the machine's own network. This
module plans it: names, addresses, the ``ip`` and ``tc`` command lines that make it, cut it,
slow it down and take it away, and the environment a process needs on either host. It runs
nothing (:mod:`walker_bringup.host_link` does).

Discovery across the link
-------------------------
Every process keeps ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and names the other host's
address in ``ROS_STATIC_PEERS``. Under LOCALHOST, rmw_fastrtps (Jazzy) clears the multicast
discovery locators and sends its participant announcements by unicast to 127.0.0.1 and to the
static peers only; the participants then announce their data locators on every interface of
their namespace, which is the loopback and the veth end. A namespace has no other interface
and no route but the link's, so whatever DDS sends stays within the two namespaces.

Shared memory
-------------
Network namespaces share the machine's ``/dev/shm``, where Fast DDS keeps its shared-memory
ports, their locks and semaphores, named by domain and participant index: two hosts sharing it
see each other's ports, which two machines never do. So each host has a ``/dev/shm`` of its
own: a directory of the machine's, bound over ``/dev/shm`` for every process run on the host.

Degraded link
-------------
``tc qdisc ... netem`` (delay, loss) needs the kernel's ``sch_netem``, absent on some machines;
a token bucket (``tbf``) is in every kernel: a low rate with a short queue delays what the
link carries and drops what overflows the queue, as a thin radio link does.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import json
import math
import re
from collections.abc import Callable, Iterable

__all__ = ['ROLES', 'Host', 'HostLink', 'TokenBucket', 'QueueCounts', 'plan_host_link',
           'host_environment', 'namespaces_listed', 'stale_namespaces', 'queue_counts',
           'shared_memory_of', 'DEFAULT_PREFIX', 'DEFAULT_SUBNET', 'STATIC_PEERS_VARIABLE',
           'DISCOVERY_RANGE_VARIABLE', 'SHARED_MEMORY']

#: The two hosts, in the order their addresses are given.
ROLES = ('robot', 'ground')
#: Names of the namespaces and interfaces when none are asked for.
DEFAULT_PREFIX = 'walker'
#: The link's subnet: it exists only inside the two namespaces, so any private one will do.
DEFAULT_SUBNET = '10.231.0.0/30'
STATIC_PEERS_VARIABLE = 'ROS_STATIC_PEERS'
DISCOVERY_RANGE_VARIABLE = 'ROS_AUTOMATIC_DISCOVERY_RANGE'
#: The machine's shared memory, which each host replaces with a directory of its own in it.
SHARED_MEMORY = '/dev/shm'
#: What a process run on a host runs first: its own shared memory bound over the machine's
#: (``$0``, in the private mount namespace ``ip netns exec`` gives it), then the command.
_OWN_SHARED_MEMORY = f'mount --bind "$0" {SHARED_MEMORY} && exec "$@"'
_IFNAME_MAX = 15  # Linux interface names: IFNAMSIZ (16) less the terminating NUL
_PREFIX_PATTERN = re.compile(r'[a-z][a-z0-9]*\Z')


@dataclasses.dataclass(frozen=True)
class Host:
    """One side of the link.

    Attributes
    ----------
    role : str
        ``'robot'`` or ``'ground'``.
    namespace : str
        The network namespace (``ip netns`` name).
    interface : str
        Its end of the veth pair.
    address : str
        Its IPv4 address on the link.
    shared_memory : str
        The directory that is its ``/dev/shm`` (:func:`shared_memory_of`).
    """

    role: str
    namespace: str
    interface: str
    address: str
    shared_memory: str


@dataclasses.dataclass(frozen=True)
class TokenBucket:
    """A link slowed down by a token bucket (``tc qdisc ... tbf``), each direction alike.

    Attributes
    ----------
    rate : float
        What the link carries [bit/s] (> 0).
    burst : int
        Bytes sent at once at full speed before the rate applies (>= one 1500-byte frame).
    latency : float
        Longest a packet may wait in the queue [s] (> 0); what would wait longer is dropped.
    """

    rate: float
    burst: int = 3000
    latency: float = 0.2

    def __post_init__(self) -> None:
        if not (isinstance(self.rate, (int, float)) and math.isfinite(self.rate)
                and self.rate > 0.0):
            raise ValueError(f'rate must be a positive number of bit/s, got {self.rate!r}')
        if not isinstance(self.burst, int) or self.burst < 1500:
            raise ValueError(f'burst must be a whole number of bytes >= 1500 (one Ethernet '
                             f'frame), got {self.burst!r}')
        if not (isinstance(self.latency, (int, float)) and math.isfinite(self.latency)
                and self.latency > 0.0):
            raise ValueError(f'latency must be a positive number of seconds, got '
                             f'{self.latency!r}')

    def tc_arguments(self) -> list[str]:
        """Return the ``tbf`` arguments of ``tc qdisc replace ... root``."""
        return ['tbf', 'rate', f'{round(self.rate)}bit', 'burst', str(self.burst),
                'latency', f'{round(self.latency * 1000.0)}ms']


@dataclasses.dataclass(frozen=True)
class QueueCounts:
    """What the queue of one end of the link has done (``tc -s qdisc``), from its making on.

    Attributes
    ----------
    sent_bytes, sent_packets : int
        What it has sent on.
    dropped : int
        Packets dropped (a token bucket: those that would have waited longer than its latency).
    overlimits : int
        Times a packet had to wait for the rate (0: the link was never slower than its load).
    """

    sent_bytes: int
    sent_packets: int
    dropped: int
    overlimits: int


@dataclasses.dataclass(frozen=True)
class HostLink:
    """Two network namespaces joined by a veth pair: what to run to make, cut and remove it.

    Build with :func:`plan_host_link`. Every method returns command lines (lists of
    arguments, for ``subprocess.run``); running them needs root (or ``CAP_NET_ADMIN``).
    """

    robot: Host
    ground: Host
    prefix_length: int

    def host(self, role: str) -> Host:
        """Return the host of ``role`` (``'robot'`` or ``'ground'``).

        Raises
        ------
        ValueError
            Another role.
        """
        if role not in ROLES:
            raise ValueError(f'host {role!r}: expected one of {", ".join(ROLES)}')
        return self.robot if role == 'robot' else self.ground

    def peer(self, role: str) -> Host:
        """Return the host at the other end of the link from ``role``."""
        return self.ground if self.host(role) is self.robot else self.robot

    @property
    def hosts(self) -> tuple[Host, Host]:
        """The robot host, then the ground host."""
        return self.robot, self.ground

    def create_commands(self) -> list[list[str]]:
        """Make both namespaces and the link, each end made inside its namespace, all up.

        Each namespace's loopback is brought up too: its own nodes find each other over it.
        Each host's shared memory is made empty, open to every user as ``/dev/shm`` is.
        """
        robot, ground = self.robot, self.ground
        commands = [['ip', 'netns', 'add', robot.namespace],
                    ['ip', 'netns', 'add', ground.namespace]]
        for host in self.hosts:
            commands += [['rm', '-rf', '--one-file-system', host.shared_memory],
                         ['mkdir', host.shared_memory], ['chmod', '1777', host.shared_memory]]
        commands.append(['ip', 'link', 'add', robot.interface, 'netns', robot.namespace,
                         'type', 'veth', 'peer', 'name', ground.interface,
                         'netns', ground.namespace])
        for host in self.hosts:
            commands += [['ip', '-n', host.namespace, 'addr', 'add',
                          f'{host.address}/{self.prefix_length}', 'dev', host.interface],
                         ['ip', '-n', host.namespace, 'link', 'set', 'lo', 'up'],
                         ['ip', '-n', host.namespace, 'link', 'set', host.interface, 'up']]
        return commands

    def delete_commands(self) -> list[list[str]]:
        """Remove both namespaces (the veth pair goes with them) and their shared memory."""
        return [['ip', 'netns', 'delete', host.namespace] for host in self.hosts] + [
            ['rm', '-rf', '--one-file-system', host.shared_memory] for host in self.hosts]

    def cut_commands(self) -> list[list[str]]:
        """Take the link down at both ends: nothing passes, each host keeps its address."""
        return [self._set_link(host, 'down') for host in self.hosts]

    def restore_commands(self) -> list[list[str]]:
        """Bring the link up again at both ends."""
        return [self._set_link(host, 'up') for host in self.hosts]

    def degrade_commands(self, bucket: TokenBucket) -> list[list[str]]:
        """Slow the link down in both directions (replacing any earlier setting)."""
        return [['tc', '-n', host.namespace, 'qdisc', 'replace', 'dev', host.interface,
                 'root', *bucket.tc_arguments()] for host in self.hosts]

    def clear_commands(self) -> list[list[str]]:
        """Give the link its full speed back (the kernel's default queue again)."""
        return [['tc', '-n', host.namespace, 'qdisc', 'del', 'dev', host.interface, 'root']
                for host in self.hosts]

    def queue_commands(self) -> list[list[str]]:
        """Show the root queue of each end with its counts, as JSON (robot, then ground)."""
        return [['tc', '-n', host.namespace, '-s', '-j', 'qdisc', 'show', 'dev',
                 host.interface] for host in self.hosts]

    def netem_probe_commands(self) -> list[list[str]]:
        """Add and remove a ``netem`` queue on the robot's loopback: both succeed iff it exists."""
        namespace = self.robot.namespace
        return [['tc', '-n', namespace, 'qdisc', 'add', 'dev', 'lo', 'root', 'netem',
                 'delay', '1ms'],
                ['tc', '-n', namespace, 'qdisc', 'del', 'dev', 'lo', 'root']]

    def exec_command(self, role: str, argv: list[str]) -> list[str]:
        """Return ``argv`` run on the host of ``role``, with the host's own shared memory.

        ``ip netns exec`` gives the command a private mount namespace, in which the host's
        directory is bound over ``/dev/shm`` before the command starts.
        """
        if not argv:
            raise ValueError('no command to run')
        host = self.host(role)
        return ['ip', 'netns', 'exec', host.namespace, 'sh', '-c', _OWN_SHARED_MEMORY,
                host.shared_memory, *argv]

    @staticmethod
    def _set_link(host: Host, state: str) -> list[str]:
        return ['ip', '-n', host.namespace, 'link', 'set', host.interface, state]


def plan_host_link(prefix: str = DEFAULT_PREFIX, subnet: str = DEFAULT_SUBNET) -> HostLink:
    """Plan the two namespaces ``<prefix>-robot`` and ``<prefix>-ground`` and their link.

    Parameters
    ----------
    prefix : str
        Lower-case letters and digits, starting with a letter; the veth ends are
        ``<prefix>-r`` and ``<prefix>-g``, so at most 13 characters.
    subnet : str
        A private IPv4 subnet with room for two hosts (``10.231.0.0/30``); the robot takes its
        first address, the ground its second.

    Raises
    ------
    ValueError
        A prefix that is not such a name, or a subnet that is not private IPv4, is loopback
        or link-local, or has room for fewer than two hosts.
    """
    if not isinstance(prefix, str) or not _PREFIX_PATTERN.match(prefix):
        raise ValueError(f'prefix {prefix!r}: expected lower-case letters and digits, starting '
                         'with a letter')
    if len(prefix) + 2 > _IFNAME_MAX:
        raise ValueError(f'prefix {prefix!r} is {len(prefix)} characters long: the interface '
                         f'{prefix}-r would be longer than Linux allows ({_IFNAME_MAX}); use at '
                         f'most {_IFNAME_MAX - 2}')
    try:
        network = ipaddress.IPv4Network(subnet, strict=True)
    except (ipaddress.AddressValueError, ipaddress.NetmaskValueError, ValueError) as error:
        raise ValueError(f'subnet {subnet!r}: {error}') from None
    if network.is_loopback or network.is_link_local or not network.is_private:
        raise ValueError(f'subnet {subnet}: expected a private IPv4 subnet (such as '
                         f'{DEFAULT_SUBNET}), not a loopback, link-local or public one')
    addresses = list(network.hosts()) if network.prefixlen < 31 else []
    if len(addresses) < 2:
        raise ValueError(f'subnet {subnet} has room for {len(addresses)} hosts: the link needs '
                         'two (a /30 or larger)')
    hosts = [Host(role, f'{prefix}-{role}', f'{prefix}-{role[0]}', str(address),
                  shared_memory_of(f'{prefix}-{role}'))
             for role, address in zip(ROLES, addresses[:2], strict=True)]
    return HostLink(hosts[0], hosts[1], network.prefixlen)


def shared_memory_of(namespace: str) -> str:
    """Return the directory that is ``/dev/shm`` on the host of network namespace ``namespace``.

    A directory of the machine's ``/dev/shm``, named after the namespace.
    """
    return f'{SHARED_MEMORY}/{namespace}'


def host_environment(link: HostLink, role: str, env: dict[str, str]) -> dict[str, str]:
    """Return ``env`` for a ROS process on the host of ``role`` (a new dict; ``env`` is kept).

    Discovery stays ``LOCALHOST`` (the host's own loopback) and reaches the other end of the
    link as a static peer.

    Raises
    ------
    ValueError
        ``env`` asks for another discovery range, or names other static peers: the process
        would look for its peers elsewhere than over the link.
    """
    peer = link.peer(role).address
    scope = env.get(DISCOVERY_RANGE_VARIABLE)
    if scope not in (None, '', 'LOCALHOST'):
        raise ValueError(f'{DISCOVERY_RANGE_VARIABLE} is {scope!r}: a host of the link keeps '
                         'LOCALHOST and reaches its peer as a static peer')
    peers = env.get(STATIC_PEERS_VARIABLE)
    if peers and peers != peer:
        raise ValueError(f'{STATIC_PEERS_VARIABLE} is already {peers!r}; the {role} host '
                         f'reaches its peer at {peer}')
    return {**env, DISCOVERY_RANGE_VARIABLE: 'LOCALHOST', STATIC_PEERS_VARIABLE: peer}


def namespaces_listed(text: str) -> list[str]:
    """Return the names in the output of ``ip netns list`` (``name`` or ``name (id: N)``)."""
    return [line.split()[0] for line in text.splitlines() if line.strip()]


def stale_namespaces(names: Iterable[str], prefix: str, alive: Callable[[int], bool]
                     ) -> list[str]:
    """Pick the namespaces ``<prefix><pid>-robot|ground`` whose process ``pid`` has ended.

    For a test that names its link ``<prefix><its pid>``: what an earlier run of it left
    behind, killed before it could remove its link. Names of any other form, and those of
    processes still alive (another run at work), are never picked.
    """
    pattern = re.compile(rf'{re.escape(prefix)}(\d+)-({"|".join(ROLES)})\Z')
    stale = []
    for name in names:
        match = pattern.match(name)
        if match and not alive(int(match.group(1))):
            stale.append(name)
    return stale


def queue_counts(text: str) -> QueueCounts:
    """Read the counts of the root queue from ``tc -s -j qdisc show dev ...``.

    Raises
    ------
    ValueError
        The text is not such JSON, or shows no root queue.
    """
    try:
        queues = json.loads(text)
        root = next(q for q in queues if q.get('root'))
        return QueueCounts(int(root['bytes']), int(root['packets']), int(root['drops']),
                           int(root['overlimits']))
    except (json.JSONDecodeError, StopIteration, KeyError, TypeError, AttributeError) as error:
        raise ValueError(f'no root queue with counts in the tc output {text[:200]!r} '
                         f'({type(error).__name__})') from None
