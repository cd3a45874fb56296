"""Process supervision (nothing left behind), graph command lines, the summary table."""

import json
import math
import os
import signal
import sys
import time
from types import SimpleNamespace

import pytest

from walker_bringup.graph import NodeSpec, controller_node_name, walker_graph
from walker_bringup.processes import ProcessGroup, read_pids
from walker_bringup.summary import format_table, rows_from_reports, write_json

ENV = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
SPEC = NodeSpec('pkg', 'exe', 'child', '/walker', 'walker.yaml')


def python_child(code):
    return [sys.executable, '-c', code]


def test_the_graph_has_every_node_with_its_arguments():
    graph = walker_graph('/tmp/walker.yaml', sim_time=True, record=True)
    names = [n.name for n in graph]
    assert names[0] == 'recorder' and names[1] == 'plant'
    assert names[2:7] == ['controller_a_yaw', 'controller_a_pitch', 'controller_vertex',
                          'controller_b_pitch', 'controller_b_yaw']
    assert names[-3:] == ['planner', 'supervisor', 'viz']
    command = graph[2].command(executable='/bin/true')
    assert command[:6] == ['/bin/true', '--ros-args', '-r', '__node:=controller_a_yaw',
                           '-r', '__ns:=/walker']
    assert '--params-file' in command and 'joint_name:=a_yaw_joint' in command
    # every node is told the clock mode: the controllers wait for owed setpoints in sim time
    # (and ask for no real-time priority), never in real time
    assert all('use_sim_time:=true' in n.command('/bin/true') for n in graph)
    assert all('use_sim_time:=false' in n.command('/bin/true')
               for n in walker_graph('/tmp/walker.yaml'))
    assert not any('realtime_priority' in arg for sim_time in (False, True)
                   for n in walker_graph('/tmp/walker.yaml', sim_time=sim_time)
                   for arg in n.command('/bin/true'))
    assert controller_node_name('vertex_joint') == 'controller_vertex'


def test_grouped_controllers_are_one_node_with_the_same_arguments():
    separate = walker_graph('/tmp/walker.yaml', sim_time=True, record=True)
    grouped = walker_graph('/tmp/walker.yaml', sim_time=True, record=True,
                           grouped_controllers=True)
    assert [n.name for n in grouped] == ['recorder', 'plant', 'controllers', 'planner',
                                         'supervisor', 'viz']
    controllers = grouped[2]
    assert (controllers.package, controllers.executable) == ('walker_control',
                                                             'joint_controllers_node')
    # every joint: the node's default joint_names; the rest as each controller's own
    assert not any('joint_name' in arg for arg in controllers.command('/bin/true'))
    assert controllers.parameters == separate[2].parameters[1:]
    assert [n for n in grouped if n.name != 'controllers'] == \
        [n for n in separate if not n.name.startswith('controller_')]


def test_refuses_to_start_nodes_without_loopback_discovery(tmp_path):
    with pytest.raises(ValueError, match='LOCALHOST'):
        ProcessGroup(tmp_path, {k: v for k, v in ENV.items()
                                if k != 'ROS_AUTOMATIC_DISCOVERY_RANGE'})


def test_a_dead_child_is_reported_once(tmp_path):
    with ProcessGroup(tmp_path, ENV) as group:
        group.start(SPEC, python_child('import sys; print("bye"); sys.exit(3)'))
        deadline = time.monotonic() + 10
        dead = []
        while not dead and time.monotonic() < deadline:
            dead = group.poll_deaths()
            time.sleep(0.05)
        assert [p.popen.returncode for p in dead] == [3]
        assert 'bye' in dead[0].log_tail()
        assert group.poll_deaths() == []


def test_a_killed_child_restarts_with_its_log_continued(tmp_path):
    with ProcessGroup(tmp_path, ENV) as group:
        first = group.start(SPEC, python_child('import sys; print("first"); sys.exit(3)'))
        first.popen.wait(timeout=10)
        second = group.restart(first, python_child('print("second")'))
        second.popen.wait(timeout=10)
        assert second.spec == first.spec and second.log_path == first.log_path
        log = second.log_path.read_text()
        assert log.index('first') < log.index('restarted') < log.index('second')
        assert 'code 3' in log
        assert group.poll_deaths() == [second], 'the replaced process is not reported again'


# A child that stops on SIGINT at once, as a node does, even when started with SIGINT ignored
# (a shell that runs the suite in the background, `cmd &`, starts it so)
_SLEEPER = ('import signal, time\n'
            'signal.signal(signal.SIGINT, signal.default_int_handler)\n'
            'time.sleep(30)\n')


def test_the_group_names_each_nodes_newest_process_id_in_its_pid_file(tmp_path):
    assert read_pids(tmp_path) == {}
    other = NodeSpec('pkg', 'exe', 'other', '/walker', 'walker.yaml')
    with ProcessGroup(tmp_path, ENV) as group:
        first = group.start(SPEC, python_child('import sys; sys.exit(3)'))
        beside = group.start(other, python_child(_SLEEPER))
        assert read_pids(tmp_path) == {'child': first.popen.pid, 'other': beside.popen.pid}
        first.popen.wait(timeout=10)
        second = group.restart(first, python_child(_SLEEPER))
        assert read_pids(tmp_path) == {'child': second.popen.pid, 'other': beside.popen.pid}
        assert sorted(p.name for p in tmp_path.iterdir()) == ['child.log', 'other.log',
                                                              'pids.json']


def test_stop_escalates_and_leaves_nothing_behind(tmp_path):
    stubborn = ('import signal, time\n'
                'signal.signal(signal.SIGINT, signal.SIG_IGN)\n'
                'signal.signal(signal.SIGTERM, signal.SIG_IGN)\n'
                'print("ready", flush=True)\n'
                'time.sleep(60)\n')
    # The polite child installs Python's SIGINT handler itself: a shell that runs the suite in
    # the background (`cmd &`) starts it with SIGINT ignored, which Python would inherit.
    polite = ('import signal, time\n'
              'signal.signal(signal.SIGINT, signal.default_int_handler)\n'
              'try:\n    print("ready", flush=True)\n    time.sleep(60)\n'
              'except KeyboardInterrupt:\n    pass\n')
    group = ProcessGroup(tmp_path, ENV)
    a = group.start(NodeSpec('p', 'e', 'stubborn', '/w', 'f'), python_child(stubborn))
    b = group.start(NodeSpec('p', 'e', 'polite', '/w', 'f'), python_child(polite))
    # Signal only once both handle signals as they mean to (start-up is slow on a loaded machine)
    deadline = time.monotonic() + 30.0
    while not all('ready' in p.log_tail() for p in (a, b)) and time.monotonic() < deadline:
        time.sleep(0.05)
    # the polite child's exit after SIGINT once took over 2 s in the full suite (load ~10)
    codes = group.stop_all(timeout=5.0)
    assert not a.alive and not b.alive
    assert codes['polite'] == 0
    # a node hung past SIGTERM is aborted: its fault handler writes where it was stuck
    assert codes['stubborn'] == -signal.SIGABRT
    log = a.log_path.read_text()
    assert 'most recent call first' in log
    # the notes stay, before what the child wrote after them (it writes in append mode)
    assert log.index('sending SIGTERM') < log.index('sending SIGABRT') \
        < log.index('most recent call first'), log
    for process in (a, b):
        with pytest.raises(ProcessLookupError):
            os.kill(process.popen.pid, 0)


# A child that notes (monotonic clock, shared by every process) when SIGINT came and when it
# ended, taking a moment to stop as a node does
_TIMED = ('import signal, sys, time\n'
          'signal.signal(signal.SIGINT, signal.default_int_handler)\n'
          'try:\n    print("ready", flush=True)\n    time.sleep(60)\n'
          'except KeyboardInterrupt:\n'
          '    print("interrupted", time.monotonic(), flush=True)\n'
          '    time.sleep(0.3)\n'
          '    print("ended", time.monotonic(), flush=True)\n')


def test_stop_all_stops_one_at_a_time_deciders_and_plant_first_recorder_last(tmp_path):
    group = ProcessGroup(tmp_path, ENV)
    names = ['recorder', 'plant', 'controller_a_yaw', 'controller_vertex', 'planner',
             'supervisor']
    processes = {name: group.start(NodeSpec('p', 'e', name, '/w', 'f'), python_child(_TIMED))
                 for name in names}

    def wait_ready(starts: dict) -> None:
        deadline = time.monotonic() + 30.0
        while not all(processes[n].log_tail().count('ready') == count
                      for n, count in starts.items()):
            assert time.monotonic() < deadline, {n: p.log_tail() for n, p in processes.items()}
            time.sleep(0.05)

    wait_ready(dict.fromkeys(names, 1))
    # a node killed and started again: its newest process is the one whose code counts
    processes['controller_a_yaw'].popen.kill()
    processes['controller_a_yaw'].popen.wait()
    processes['controller_a_yaw'] = group.restart(processes['controller_a_yaw'],
                                                  python_child(_TIMED))
    wait_ready({'controller_a_yaw': 2})
    codes = group.stop_all(timeout=10.0)
    assert codes == dict.fromkeys(names, 0)

    def moment(name, what):
        line = [t for t in processes[name].log_tail(5).splitlines() if t.startswith(what)][-1]
        return float(line.split()[1])
    order = sorted(names, key=lambda name: moment(name, 'interrupted'))
    assert order == ['supervisor', 'planner', 'plant', 'controller_a_yaw',
                     'controller_vertex', 'recorder']  # newest first between first and last
    for before, after in zip(order[:-1], order[1:], strict=True):
        assert moment(after, 'interrupted') > moment(before, 'ended'), (before, after)


def test_only_shared_memory_no_live_process_uses_is_stale(tmp_path, monkeypatch):
    from walker_bringup import processes

    monkeypatch.setattr(processes, '_SHM', tmp_path)
    before = processes.fastdds_shm_files()
    names = ['fastrtps_live', 'fastrtps_live_el', 'fastrtps_dead', 'fastrtps_dead_el',
             'sem.fastrtps_port7001_mutex', 'fastrtps_young']
    old = time.time() - 60.0
    for name in names:
        (tmp_path / name).write_bytes(b'')
        if name != 'fastrtps_young':
            os.utime(tmp_path / name, (old, old))
    monkeypatch.setattr(processes, '_mapped_shared_memory',
                        lambda: {'fastrtps_live', 'fastrtps_port7001_mutex'})
    stale = processes.stale_shared_memory_files(before)
    # a live segment's lock file stays with it: Fast DDS would take the segment for dead
    assert [p.name for p in stale] == ['fastrtps_dead', 'fastrtps_dead_el']


def report(index, success=True, duration=6.0, bound=4.0):
    return SimpleNamespace(
        step_index=index, moving_gripper='b', from_node='n2_1', to_node='n0_1', sweep=math.pi,
        success=success, phase_names=['extraction', 'coarse', 'fine', 'insertion'],
        phase_durations=[0.6, 3.0, 1.2, 1.2], duration=duration, time_optimal_bound=bound,
        insertion_error=0.0004, insertion_error_estimated=0.0003, residual_vibration=0.0002,
        insertion_attempts=1, message='' if success else 'insertion jammed 3 times')


def test_summary_table_and_json(tmp_path):
    rows = rows_from_reports([report(0), report(1, success=False, bound=0.0)])
    assert rows[0].bound_ratio == pytest.approx(1.5)
    assert math.isnan(rows[1].bound_ratio)
    table = format_table(rows)
    lines = table.splitlines()
    assert 'ratio' in lines[0] and 'ins. err mm' in lines[0]
    assert '1.50' in lines[2] and '0.40' in lines[2] and '+180' in lines[2]
    assert 'NO' in lines[3] and 'step 2: insertion jammed 3 times' in table
    assert lines[4].split()[0] == 'all'
    write_json(rows, tmp_path / 's.json', {'target': 'n0_1'})
    data = json.loads((tmp_path / 's.json').read_text())
    assert data['target'] == 'n0_1' and data['steps'][1]['bound_ratio'] is None
    assert data['steps'][0]['phase_durations']['coarse'] == 3.0


def test_the_walk_report_is_made_unless_skipped():
    from walker_bringup.run import parse_arguments

    assert parse_arguments([]).report is True
    assert parse_arguments(['--no-report']).report is False


def test_a_report_that_cannot_be_made_is_said_and_leaves_nothing(tmp_path, capsys):
    from walker_report.walk_report import report_after_walk as write_report

    cut = tmp_path / 'bag'
    cut.mkdir()
    (cut / 'bag_0.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\0' * 64)  # no footer
    assert write_report(cut, tmp_path / 'report', None, quiet=True) is False
    printed = capsys.readouterr().out
    assert '[walker] error: no walk report:' in printed and '--recover' in printed
    assert not (tmp_path / 'report').exists()


@pytest.mark.parametrize('walkers, taken', [(1, 'bag'), (2, 'bag_walker_2')])
def test_an_output_directory_holding_a_bag_is_refused_before_anything_starts(
        tmp_path, capsys, monkeypatch, walkers, taken):
    from walker_bringup.run import main
    from walker_bringup.transport import PROFILES_VARIABLE

    (tmp_path / taken).mkdir()
    monkeypatch.delenv(PROFILES_VARIABLE, raising=False)
    code = main(['--sim-time', '--quiet', '--walkers', str(walkers), '--out', str(tmp_path)])
    printed = capsys.readouterr().out
    assert code == 2
    # the graph's transport profile is not left behind for the next graph of this process
    # (one with peers on other hosts would otherwise inherit UDP on loopback)
    assert PROFILES_VARIABLE not in os.environ
    assert f'[walker] error: {tmp_path / taken} already exists' in printed  # said, even quiet
    assert '--no-record' in printed
    assert not list(tmp_path.rglob('*.log'))  # no node was started


def test_walk_progress_names_the_step_under_way_and_counts_the_steps_done_between_them():
    from walker_msgs.action import WalkTo

    from walker_core.progress import walk_progress

    def walk_feedback_text(feedback, elapsed):
        return walk_progress(feedback.step_index, feedback.step_count, feedback.phase,
                             feedback.from_node, feedback.to_node,
                             feedback.tip_position_error, elapsed)

    during = WalkTo.Feedback(step_index=4, step_count=5, phase=3, from_node='n3_2',
                             to_node='n4_3', tip_position_error=0.0059)
    assert walk_feedback_text(during, 46.2) == \
        'step 5/5 n3_2 -> n4_3: fine, tip error 5.9 mm (46 s)'
    after_the_last = WalkTo.Feedback(step_index=5, step_count=5, phase=0)
    assert walk_feedback_text(after_the_last, 50.0) == '5 of 5 steps done: idle (50 s)'


@pytest.mark.parametrize('target, reason', [
    ('n99_99', "node 'n99_99' is not on the truss"),
    ('elsewhere', "'elsewhere' is not a node name")])
def test_a_target_that_is_no_node_is_refused_before_anything_starts(tmp_path, capsys, target,
                                                                     reason):
    from walker_bringup.run import main

    out = tmp_path / 'out'
    code = main(['--sim-time', '--quiet', '--target', target, '--out', str(out)])
    printed = capsys.readouterr().out
    assert code == 2
    assert f"[walker] error: --target '{target}': {reason}" in printed
    assert not out.exists()  # no bag, no report, no log


def test_serve_records_in_files_of_bounded_size_and_age_and_keeps_the_newest():
    from walker_bringup.graph_walkers import graph_parameters
    from walker_bringup.run import SERVE_SPLIT, parse_arguments, session_options

    walk = parse_arguments([])
    assert (walk.max_bag_size, walk.max_bag_duration, walk.max_bag_files) == (0, 0.0, 0)
    serve = parse_arguments(['--serve'])
    assert (serve.max_bag_size, serve.max_bag_duration, serve.max_bag_files) == SERVE_SPLIT
    chosen = parse_arguments(['--serve', '--max-bag-files', '0', '--max-bag-duration', '60'])
    assert dict(graph_parameters(session_options(chosen))) == {
        'recorder.max_bag_size': str(SERVE_SPLIT[0]), 'recorder.max_bag_duration': '60.0',
        'recorder.max_bag_files': '0'}


@pytest.mark.parametrize('option, value', [('--max-bag-size', '-1'),
                                           ('--max-bag-duration', 'nan'),
                                           ('--max-bag-files', '1.5')])
def test_a_bad_split_limit_is_refused_by_the_command_line(option, value, capsys):
    from walker_bringup.run import parse_arguments

    with pytest.raises(SystemExit) as exit_:
        parse_arguments([option, value])
    assert exit_.value.code == 2
    assert option in capsys.readouterr().err


def test_a_bag_its_recorder_left_cut_is_completed_once_the_graph_is_down(tmp_path):
    from mcap.reader import make_reader

    from walker_bag.core.bag_metadata import TopicMetadata
    from walker_bag.core.bag_writer import BagWriter
    from walker_bringup.graph_walkers import recover_bags as _recover_bags

    bag = tmp_path / 'bag'
    with BagWriter(bag) as writer:
        writer.add_topic(TopicMetadata('/walker/x', 'std_msgs/msg/Empty'), None)
        for i in range(5):
            writer.write('/walker/x', b'\x00\x01\x00\x00', 10**9 + i)
        writer.flush()
        cut = (bag / 'bag_0.mcap').read_bytes()  # what a recorder killed now leaves
    (bag / 'bag_0.mcap').write_bytes(cut)
    said = _recover_bags([bag, tmp_path / 'never_recorded'])
    assert said == [f'[walker] the recorder of {bag} did not close it: its cut file completed '
                    'in place, 5 messages (the cut file kept as bag_0.mcap.incomplete)']
    with open(bag / 'bag_0.mcap', 'rb') as stream:
        assert len(list(make_reader(stream).iter_messages())) == 5
    assert _recover_bags([bag]) == []  # complete now: nothing to say


def test_the_walk_summary_takes_what_the_bag_lacks_from_its_own_record(tmp_path):
    """A frozen recorder's losses and a killed one's gap: from the bag's metadata, as flushed."""
    from walker_bag.core.bag_writer import BagWriter
    from walker_core.robot_parameters import default_parameter_file
    from walker_bringup.graph_walkers import GraphWalker

    bag = tmp_path / 'bag'
    nodes = walker_graph(default_parameter_file(), record=True, bag_path=bag)
    walker = GraphWalker('/walker', None, nodes, ProcessGroup(
        tmp_path / 'logs', {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}))
    assert walker.recording() is None  # no bag yet
    with BagWriter(bag, custom_data={
            'messages_lost': '405', 'messages_lost /walker/joint_states': '405',
            'recorder_gap /walker/joint_states': '1000000000 2670000000 834'}):
        pass
    recording = walker.recording()
    assert recording['messages_lost'] == 405
    assert recording['not_recorded'] == [pytest.approx(
        {'topic': '/walker/joint_states', 'start': 1.0, 'end': 2.67, 'span': 1.67,
         'estimated': 834})]
    path = tmp_path / 'summary.json'
    write_json([], path, {'recording': recording})
    assert json.loads(path.read_text())['recording']['not_recorded'][0]['estimated'] == 834
