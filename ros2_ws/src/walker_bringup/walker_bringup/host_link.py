"""A robot host and a ground host on this machine, made, cut and removed (``ip``, ``tc``).

Applies the plans of :mod:`walker_bringup.core.host_link`: :class:`LinkedHosts` makes the two
network namespaces and their veth link (and removes whatever it made if a step fails), runs a
command on either host with the environment its ROS discovery needs, cuts the link and brings
it back, slows it down with a token bucket. As a context manager it removes both namespaces on
the way out, however the block ends. Needs root (or ``CAP_NET_ADMIN``).

From a clone, ``scripts/ground_station.py`` runs :func:`main` (``--help`` for the commands);
docs/ground_station.md shows a session by hand.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

from walker_bringup.core.host_link import (
    DEFAULT_PREFIX, DEFAULT_SUBNET, ROLES, HostLink, QueueCounts, TokenBucket,
    host_environment, namespaces_listed, plan_host_link, queue_counts, shared_memory_of,
    stale_namespaces)

__all__ = ['LinkedHosts', 'LinkCommandError', 'existing_namespaces', 'remove_stale', 'main']

_COMMAND_TIMEOUT = 30.0  # [s] an ip or tc command that takes longer has hung


class LinkCommandError(RuntimeError):
    """An ``ip`` or ``tc`` command failed (its command line and what it printed are said)."""


def _run(command: list[str], check: bool = True) -> subprocess.CompletedProcess:
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=_COMMAND_TIMEOUT)
    except FileNotFoundError:
        raise LinkCommandError(f'{command[0]} is not installed (iproute2)') from None
    except subprocess.TimeoutExpired:
        raise LinkCommandError(f'{" ".join(command)} did not end in '
                               f'{_COMMAND_TIMEOUT:g} s') from None
    if check and done.returncode != 0:
        raise LinkCommandError(f'{" ".join(command)} failed (exit code {done.returncode}): '
                               f'{(done.stderr or done.stdout).strip()}')
    return done


def existing_namespaces() -> list[str]:
    """Return the names of this machine's network namespaces (``ip netns list``)."""
    return namespaces_listed(_run(['ip', 'netns', 'list']).stdout)


def remove_stale(prefix: str) -> list[str]:
    """Remove the namespaces ``<prefix><pid>-...`` of processes that have ended; return them.

    What a killed earlier run of a test that names its link after its process id left behind;
    another run still at work keeps its own.
    """
    def alive(pid: int) -> bool:
        return os.path.exists(f'/proc/{pid}')

    stale = stale_namespaces(existing_namespaces(), prefix, alive)
    for name in stale:
        _run(['ip', 'netns', 'delete', name], check=False)
        _run(['rm', '-rf', '--one-file-system', shared_memory_of(name)], check=False)
    return stale


class LinkedHosts:
    """The two hosts of a :class:`~walker_bringup.core.host_link.HostLink`, made real.

    Parameters
    ----------
    link : HostLink
        The plan (:func:`~walker_bringup.core.host_link.plan_host_link`).
    """

    def __init__(self, link: HostLink) -> None:
        self.link = link

    def create(self) -> None:
        """Make both namespaces and the link; on a failure, remove what was made and raise.

        Raises
        ------
        LinkCommandError
            A namespace of that name exists already (nothing is touched then), or a step
            failed.
        """
        taken = set(existing_namespaces()) & {h.namespace for h in self.link.hosts}
        if taken:
            raise LinkCommandError(f'the network namespaces of this link exist already '
                                   f'({", ".join(sorted(taken))}): remove them '
                                   '(ground_station.py down) or choose another --prefix')
        try:
            for command in self.link.create_commands():
                _run(command)
        except BaseException:
            self.delete()
            raise

    def delete(self) -> None:
        """Remove both namespaces (those that exist) and the hosts' shared memory.

        The link and its settings go with the namespaces.
        """
        present = set(existing_namespaces())
        for command in self.link.delete_commands():
            if command[:3] != ['ip', 'netns', 'delete'] or command[3] in present:
                _run(command, check=False)

    def cut(self) -> None:
        """Take the link down at both ends."""
        self._run_all(self.link.cut_commands())

    def restore(self) -> None:
        """Bring the link up again."""
        self._run_all(self.link.restore_commands())

    def degrade(self, bucket: TokenBucket) -> None:
        """Slow the link down (a token bucket each way)."""
        self._run_all(self.link.degrade_commands(bucket))

    def clear(self) -> None:
        """Give the link its full speed back."""
        self._run_all(self.link.clear_commands())

    def queue_counts(self) -> dict[str, QueueCounts]:
        """Return what each end's queue has sent, dropped and held back, by role."""
        return {host.role: queue_counts(_run(command).stdout)
                for host, command in zip(self.link.hosts, self.link.queue_commands(),
                                         strict=True)}

    def netem_available(self) -> bool:
        """Tell whether this kernel has ``netem`` (delay and loss); leaves nothing behind."""
        add, remove = self.link.netem_probe_commands()
        if _run(add, check=False).returncode != 0:
            return False
        _run(remove, check=False)
        return True

    def command(self, role: str, argv: list[str]) -> list[str]:
        """Return ``argv`` run on the host of ``role``."""
        return self.link.exec_command(role, argv)

    def environment(self, role: str, env: dict[str, str] | None = None) -> dict[str, str]:
        """Return the environment of a ROS process on the host of ``role`` (default: ours)."""
        return host_environment(self.link, role, dict(os.environ if env is None else env))

    @staticmethod
    def _run_all(commands: list[list[str]]) -> None:
        for command in commands:
            _run(command)

    def __enter__(self) -> 'LinkedHosts':
        self.create()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.delete()


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='ground_station.py',
        description='A robot host and a ground host on this machine: two network namespaces '
                    '(<prefix>-robot, <prefix>-ground) joined by a veth link, for running the '
                    'walker graph on one and walkerctl on the other. Needs root.',
        epilog='example: ground_station.py up; ground_station.py exec robot -- python3 '
               'scripts/run_all.py --serve --sim-time; (another shell) ground_station.py exec '
               'ground -- scripts/walkerctl status; ground_station.py cut; ... restore; down')
    parser.add_argument('--prefix', default=DEFAULT_PREFIX,
                        help='names of the namespaces and interfaces (default: %(default)s)')
    parser.add_argument('--subnet', default=DEFAULT_SUBNET,
                        help="the link's private IPv4 subnet (default: %(default)s)")
    commands = parser.add_subparsers(dest='command', required=True)
    commands.add_parser('up', help='make both namespaces and the link')
    commands.add_parser('down', help='remove both namespaces (and the link)')
    commands.add_parser('cut', help='take the link down at both ends')
    commands.add_parser('restore', help='bring the link up again')
    degrade = commands.add_parser('degrade', help='slow the link down (tc tbf, each way)')
    degrade.add_argument('--rate', type=float, required=True, help='bit/s the link carries')
    degrade.add_argument('--burst', type=int, default=3000, help='bytes (default: %(default)s)')
    degrade.add_argument('--latency', type=float, default=0.2,
                         help='longest wait in the queue [s], beyond which a packet is dropped '
                              '(default: %(default)s)')
    commands.add_parser('clear', help='give the link its full speed back')
    run = commands.add_parser('exec', help='run a command on a host, its ROS discovery set '
                                           'to reach the other host over the link')
    run.add_argument('role', choices=ROLES)
    run.add_argument('argv', nargs=argparse.REMAINDER, help='the command (after --)')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``ground_station.py``; return its exit code (2: bad arguments, 1: a command failed)."""
    args = _parser().parse_args(argv)
    try:
        hosts = LinkedHosts(plan_host_link(args.prefix, args.subnet))
        if args.command == 'exec':
            command = args.argv[1:] if args.argv[:1] == ['--'] else args.argv
            full = hosts.command(args.role, command)
            env = hosts.environment(args.role)
            os.execvpe(full[0], full, env)
        bucket = (TokenBucket(args.rate, args.burst, args.latency)
                  if args.command == 'degrade' else None)
    except ValueError as error:
        print(f'ground_station.py: error: {error}', file=sys.stderr)
        return 2
    actions = {'up': hosts.create, 'down': hosts.delete, 'cut': hosts.cut,
               'restore': hosts.restore, 'clear': hosts.clear,
               'degrade': lambda: hosts.degrade(bucket)}
    try:
        actions[args.command]()
    except LinkCommandError as error:
        print(f'ground_station.py: error: {error}', file=sys.stderr)
        return 1
    if args.command == 'up':
        for host in hosts.link.hosts:
            print(f'{host.role}: namespace {host.namespace}, {host.interface} {host.address}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
