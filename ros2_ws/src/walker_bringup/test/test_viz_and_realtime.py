"""What run_all.py starts for a ROS user's tools, and what it asks of the scheduler."""

import pytest

from walker_config.core.configuration import load_configuration
from walker_bringup.graph import several_walkers, walker_graph
from walker_bringup.graph_walkers import graph_parameters
from walker_bringup.run import REALTIME_PRIORITY, parse_arguments, session_options


def graph_parameters_of(args):
    return graph_parameters(session_options(args))


def test_the_graph_publishes_tf_and_markers_and_records_them():
    graph = walker_graph('/tmp/walker.yaml', sim_time=True, record=True)
    viz = next(n for n in graph if n.name == 'viz')
    assert (viz.package, viz.executable, viz.full_name) == ('walker_viz', 'viz_node',
                                                            '/walker/viz')
    recorder = dict(graph[0].parameters)['recorder.topics']
    for topic in ("'/tf'", "'/tf_static'", "'markers'"):
        assert topic in recorder


def test_foxglove_is_served_only_when_asked_on_the_port_asked():
    assert not any(n.executable == 'foxglove_bridge' for n in walker_graph('/tmp/w.yaml'))
    graph = walker_graph('/tmp/w.yaml', foxglove_port=9000)
    bridge = next(n for n in graph if n.executable == 'foxglove_bridge')
    assert ('port', '9000') in bridge.parameters and bridge.full_name == '/walker/foxglove_bridge'
    args = parse_arguments(['--foxglove', '--foxglove-port', '0'])
    assert args.foxglove and args.foxglove_port == 0
    with pytest.raises(SystemExit):
        parse_arguments(['--foxglove-port', '70000'])


def test_each_walker_of_several_has_its_own_tf_and_records_it():
    graphs = several_walkers(load_configuration(), 2, sim_time=True, record=True,
                             bag_dir='/tmp/bags')
    first, second = (nodes for _, _, nodes in graphs)
    assert not any(dict(n.remaps).get('/tf') for n in first)  # the single walker's graph
    assert all(dict(n.remaps)['/tf'] == '/walker_2/tf' for n in second)
    assert all(dict(n.remaps)['/tf_static'] == '/walker_2/tf_static' for n in second)
    topics = dict(second[0].parameters)['recorder.topics']
    assert "'/walker_2/tf'" in topics and "'/tf'" not in topics


def test_real_time_priority_is_asked_for_only_with_realtime():
    """An idle SCHED_FIFO graph starved the machine's own tools: never by default."""
    assert load_configuration().walker.timing.realtime_priority == 0
    assert not any('realtime' in name for name, _ in graph_parameters_of(parse_arguments([])))
    asked = graph_parameters_of(parse_arguments(['--realtime']))
    assert ('timing.realtime_priority', str(REALTIME_PRIORITY)) in asked
    assert ('timing.realtime_priority', '70') in graph_parameters_of(
        parse_arguments(['--realtime', '70']))
    # in sim time the lock-step has no deadlines: nothing is asked
    assert not any(name == 'timing.realtime_priority' for name, _ in graph_parameters_of(
        parse_arguments(['--realtime', '--sim-time'])))
    for bad in ('0', '100', 'high'):
        with pytest.raises(SystemExit):
            parse_arguments(['--realtime', bad])
