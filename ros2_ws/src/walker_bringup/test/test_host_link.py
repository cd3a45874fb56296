"""The plan of a robot host and a ground host (network namespaces and their link), ROS-free."""

import ipaddress

import pytest

from walker_bringup.core.host_link import (
    HostLink, QueueCounts, TokenBucket, host_environment, namespaces_listed, plan_host_link,
    queue_counts, stale_namespaces)


def test_the_plan_names_both_hosts_and_gives_them_the_subnets_first_two_addresses():
    link = plan_host_link('wkn42', '10.9.8.0/30')
    assert (link.robot.namespace, link.robot.interface, link.robot.address) == (
        'wkn42-robot', 'wkn42-r', '10.9.8.1')
    assert (link.ground.namespace, link.ground.interface, link.ground.address) == (
        'wkn42-ground', 'wkn42-g', '10.9.8.2')
    assert link.peer('robot') == link.ground and link.peer('ground') == link.robot
    assert ipaddress.ip_address(link.robot.address) in ipaddress.ip_network('10.9.8.0/30')


def test_each_end_of_the_link_is_made_inside_its_namespace_never_on_the_machine():
    link = plan_host_link('wkn42')
    commands = link.create_commands()
    assert commands[:2] == [['ip', 'netns', 'add', 'wkn42-robot'],
                            ['ip', 'netns', 'add', 'wkn42-ground']]
    # each host's shared memory made anew, empty, in the machine's /dev/shm
    memory = [c for c in commands if c[0] != 'ip']
    assert memory == [['rm', '-rf', '--one-file-system', '/dev/shm/wkn42-robot'],
                      ['mkdir', '/dev/shm/wkn42-robot'], ['chmod', '1777', '/dev/shm/wkn42-robot'],
                      ['rm', '-rf', '--one-file-system', '/dev/shm/wkn42-ground'],
                      ['mkdir', '/dev/shm/wkn42-ground'],
                      ['chmod', '1777', '/dev/shm/wkn42-ground']]
    commands = [c for c in commands if c[0] == 'ip']
    veth = commands[2]
    assert veth[:3] == ['ip', 'link', 'add'] and 'veth' in veth
    # each end is created with its namespace named: it never exists in the machine's own
    assert veth[veth.index('wkn42-r') + 1:veth.index('wkn42-r') + 3] == ['netns', 'wkn42-robot']
    assert veth[veth.index('wkn42-g') + 1:veth.index('wkn42-g') + 3] == ['netns',
                                                                        'wkn42-ground']
    # every later command is scoped to one of the two namespaces
    for command in commands[3:]:
        assert command[:3] in (['ip', '-n', 'wkn42-robot'], ['ip', '-n', 'wkn42-ground'])
    ups = [c for c in commands if c[-1] == 'up']
    assert {(c[2], c[-2]) for c in ups} == {('wkn42-robot', 'lo'), ('wkn42-ground', 'lo'),
                                            ('wkn42-robot', 'wkn42-r'),
                                            ('wkn42-ground', 'wkn42-g')}


def test_cut_restore_degrade_and_remove_touch_only_the_two_namespaces():
    link = plan_host_link('wkn42')
    assert link.cut_commands() == [['ip', '-n', 'wkn42-robot', 'link', 'set', 'wkn42-r', 'down'],
                                   ['ip', '-n', 'wkn42-ground', 'link', 'set', 'wkn42-g',
                                    'down']]
    assert [c[-1] for c in link.restore_commands()] == ['up', 'up']
    degrade = link.degrade_commands(TokenBucket(64000.0, 3000, 0.2))
    assert degrade[0] == ['tc', '-n', 'wkn42-robot', 'qdisc', 'replace', 'dev', 'wkn42-r',
                          'root', 'tbf', 'rate', '64000bit', 'burst', '3000',
                          'latency', '200ms']
    assert [c[2] for c in degrade + link.clear_commands()] == ['wkn42-robot', 'wkn42-ground'] * 2
    assert link.delete_commands() == [['ip', 'netns', 'delete', 'wkn42-robot'],
                                      ['ip', 'netns', 'delete', 'wkn42-ground'],
                                      ['rm', '-rf', '--one-file-system', '/dev/shm/wkn42-robot'],
                                      ['rm', '-rf', '--one-file-system', '/dev/shm/wkn42-ground']]
    assert all(c[1:3] == ['-n', 'wkn42-robot'] for c in link.netem_probe_commands())


def test_a_process_on_a_host_has_the_hosts_own_shared_memory_as_on_a_machine_of_its_own():
    """Fast DDS's shared-memory ports of one host must not be seen from the other."""
    link = plan_host_link('wkn42')
    command = link.exec_command('ground', ['walkerctl', 'status'])
    assert command[:4] == ['ip', 'netns', 'exec', 'wkn42-ground']
    assert command[-2:] == ['walkerctl', 'status']
    shell = command[4:-2]
    assert shell[:2] == ['sh', '-c'] and shell[3] == '/dev/shm/wkn42-ground'
    assert shell[2] == 'mount --bind "$0" /dev/shm && exec "$@"'
    assert link.robot.shared_memory == '/dev/shm/wkn42-robot' != link.ground.shared_memory


def test_a_process_on_a_host_keeps_localhost_discovery_and_names_its_peer():
    link = plan_host_link('wkn42', '10.9.8.0/30')
    env = {'ROS_DOMAIN_ID': '7'}
    robot = host_environment(link, 'robot', env)
    assert robot == {'ROS_DOMAIN_ID': '7', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                     'ROS_STATIC_PEERS': '10.9.8.2'}
    assert host_environment(link, 'ground', robot | {'ROS_STATIC_PEERS': ''})[
        'ROS_STATIC_PEERS'] == '10.9.8.1'
    assert env == {'ROS_DOMAIN_ID': '7'}  # the caller's is kept
    assert host_environment(link, 'robot', robot) == robot  # twice: the same


@pytest.mark.parametrize('env, named', [
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'}, 'SUBNET'),
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SYSTEM_DEFAULT'}, 'SYSTEM_DEFAULT'),
    ({'ROS_STATIC_PEERS': '192.168.1.5'}, '192.168.1.5'),
])
def test_an_environment_that_would_look_elsewhere_is_refused(env, named):
    with pytest.raises(ValueError, match=named):
        host_environment(plan_host_link(), 'robot', env)


@pytest.mark.parametrize('prefix, subnet, named', [
    ('Walker', '10.231.0.0/30', 'lower-case'),
    ('walker-x', '10.231.0.0/30', 'lower-case'),
    ('', '10.231.0.0/30', 'lower-case'),
    ('1walker', '10.231.0.0/30', 'starting with a letter'),
    ('abcdefghijklmn', '10.231.0.0/30', 'longer than Linux allows'),
    ('walker', '8.8.8.0/30', 'private'),
    ('walker', '127.0.0.0/30', 'loopback'),
    ('walker', '169.254.1.0/30', 'link-local'),
    ('walker', '10.231.0.0/31', 'room for 0 hosts'),
    ('walker', '10.231.0.1/30', "'10.231.0.1/30'"),
    ('walker', 'fd00::/64', "'fd00::/64'"),
    ('walker', 'ten', "'ten'"),
])
def test_bad_names_and_subnets_are_refused_naming_what_is_wrong(prefix, subnet, named):
    with pytest.raises(ValueError, match=named):
        plan_host_link(prefix, subnet)


def test_an_unknown_host_is_refused():
    link = plan_host_link()
    with pytest.raises(ValueError, match="host 'station'"):
        link.host('station')
    with pytest.raises(ValueError, match='no command'):
        link.exec_command('robot', [])


@pytest.mark.parametrize('kwargs, named', [
    ({'rate': 0.0}, 'rate'), ({'rate': float('nan')}, 'rate'), ({'rate': -5.0}, 'rate'),
    ({'rate': 1e5, 'burst': 100}, 'burst'), ({'rate': 1e5, 'burst': 2000.5}, 'burst'),
    ({'rate': 1e5, 'latency': 0.0}, 'latency'), ({'rate': 1e5, 'latency': float('inf')},
                                                 'latency'),
])
def test_a_token_bucket_out_of_range_is_refused(kwargs, named):
    with pytest.raises(ValueError, match=named):
        TokenBucket(**kwargs)


def test_namespaces_are_read_from_ip_netns_list_and_only_dead_runs_leftovers_are_stale():
    listed = namespaces_listed('wkn12-robot (id: 3)\nwkn12-ground (id: 2)\nwkn34-robot\n'
                               'wkn34-ground\nwalker-robot\nwkn56-robotx\nother\n\n')
    assert listed == ['wkn12-robot', 'wkn12-ground', 'wkn34-robot', 'wkn34-ground',
                      'walker-robot', 'wkn56-robotx', 'other']
    alive = {34}.__contains__
    assert stale_namespaces(listed, 'wkn', alive) == ['wkn12-robot', 'wkn12-ground']


def test_the_plan_is_a_frozen_value():
    link = plan_host_link()
    assert isinstance(link, HostLink)
    with pytest.raises(AttributeError):
        link.robot = link.ground


def test_the_queue_counts_are_read_from_tc_json():
    text = ('[{"kind":"tbf","handle":"800b:","root":true,"refcnt":3,"options":{"rate":125000,'
            '"burst":3000,"lat":300000},"bytes":5120,"packets":12,"drops":3,"overlimits":40,'
            '"requeues":0,"backlog":0,"qlen":0}]')
    assert queue_counts(text) == QueueCounts(5120, 12, 3, 40)
    assert plan_host_link('wkn42').queue_commands()[1] == [
        'tc', '-n', 'wkn42-ground', '-s', '-j', 'qdisc', 'show', 'dev', 'wkn42-g']


@pytest.mark.parametrize('text', ['', 'qdisc tbf 800b: root', '[]', '[{"kind": "tbf"}]',
                                  '[{"root": true, "bytes": 1}]', '{"root": true}'])
def test_tc_output_without_a_root_queue_is_refused(text):
    with pytest.raises(ValueError, match='no root queue'):
        queue_counts(text)


class _FakeIp:
    """Stands in for ``ip``: records each command, fails the one that contains ``fail_on``."""

    def __init__(self, namespaces=(), fail_on=''):
        self.namespaces = list(namespaces)
        self.fail_on = fail_on
        self.commands = []

    def __call__(self, command, check=True):
        import subprocess

        from walker_bringup.host_link import LinkCommandError

        self.commands.append(command)
        if command[:3] == ['ip', 'netns', 'list']:
            return subprocess.CompletedProcess(command, 0, '\n'.join(self.namespaces), '')
        if self.fail_on and self.fail_on in command:
            if check:
                raise LinkCommandError(f'{" ".join(command)} failed')
            return subprocess.CompletedProcess(command, 1, '', 'failed')
        if command[:3] == ['ip', 'netns', 'add']:
            self.namespaces.append(command[3])
        if command[:3] == ['ip', 'netns', 'delete']:
            self.namespaces.remove(command[3])
        return subprocess.CompletedProcess(command, 0, '', '')


def test_hosts_made_halfway_are_removed_and_the_failure_said(monkeypatch):
    from walker_bringup import host_link
    from walker_bringup.host_link import LinkCommandError, LinkedHosts

    ip = _FakeIp(fail_on='veth')
    monkeypatch.setattr(host_link, '_run', ip)
    hosts = LinkedHosts(plan_host_link('wkn42'))
    with pytest.raises(LinkCommandError, match='veth'):
        hosts.create()
    assert ip.namespaces == []  # both namespaces made before the failure are gone again
    assert ['ip', 'netns', 'delete', 'wkn42-robot'] in ip.commands


def test_hosts_that_exist_already_are_refused_and_left_alone(monkeypatch):
    from walker_bringup import host_link
    from walker_bringup.host_link import LinkCommandError, LinkedHosts

    ip = _FakeIp(namespaces=['wkn42-robot', 'other'])
    monkeypatch.setattr(host_link, '_run', ip)
    with pytest.raises(LinkCommandError, match=r'exist already \(wkn42-robot\)'):
        LinkedHosts(plan_host_link('wkn42')).create()
    assert ip.namespaces == ['wkn42-robot', 'other']
    assert all(c[:3] == ['ip', 'netns', 'list'] for c in ip.commands)


def test_the_hosts_are_removed_however_the_block_ends(monkeypatch):
    from walker_bringup import host_link
    from walker_bringup.host_link import LinkedHosts

    ip = _FakeIp(namespaces=['other'])
    monkeypatch.setattr(host_link, '_run', ip)
    with pytest.raises(KeyboardInterrupt), LinkedHosts(plan_host_link('wkn42')) as hosts:
        assert ip.namespaces == ['other', 'wkn42-robot', 'wkn42-ground']
        hosts.cut()
        raise KeyboardInterrupt
    assert ip.namespaces == ['other']
