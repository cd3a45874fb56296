"""Several walkers' graphs, and the composed graph built from the same descriptions."""

from pathlib import Path

import pytest

from walker_bringup.composition import (
    COMPONENTS, ComposedGraph, CompositionError, component_of, composed_command,
    graph_from_arguments, parse_arguments)
from walker_bringup.graph import (
    NodeSpec, StartStance, several_walkers, start_stances, walker_graph, walker_namespace,
    walker_targets)
from walker_bringup.run import parse_arguments as run_arguments
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_core.truss import Truss, UnknownNodeError

PARAMS = Path(default_parameter_file()).resolve()


def test_walker_namespaces():
    assert [walker_namespace(i) for i in (1, 2, 4)] == ['/walker', '/walker_2', '/walker_4']
    for bad in (0, -1, 1.0, True, '2'):
        with pytest.raises(ValueError, match='walker index'):
            walker_namespace(bad)


@pytest.mark.parametrize('count', [1, 2, 4, 8])
def test_start_stances_are_distinct_neighbouring_nodes_on_the_truss(count):
    truss = Truss.from_parameters(load_walker_parameters(PARAMS))
    stances = start_stances(PARAMS, count)
    assert len(stances) == count
    # the first walker starts where the parameter file says
    assert stances[0] == StartStance('a', 'n1_1', 'n2_1')
    nodes = [n for s in stances for n in (s.base_node, s.other_node)]
    assert len(set(nodes)) == len(nodes)
    for stance in stances:
        assert stance.other_node in truss.neighbors(stance.base_node)


def test_more_walkers_than_the_truss_holds_or_no_walker_is_refused():
    with pytest.raises(ValueError, match='room for 8 walkers'):
        start_stances(PARAMS, 9)
    for bad in (0, -2, 2.5, True):
        with pytest.raises(ValueError, match='positive integer'):
            start_stances(PARAMS, bad)


def test_several_walkers_get_their_namespace_start_and_clock():
    graphs = several_walkers(PARAMS, 3, sim_time=True)
    assert [ns for ns, _, _ in graphs] == ['/walker', '/walker_2', '/walker_3']
    # the first walker's graph is exactly the single walker's
    assert graphs[0][2] == walker_graph(PARAMS, '/walker', sim_time=True)
    for namespace, start, nodes in graphs[1:]:
        assert all(n.namespace == namespace for n in nodes)
        assert all(dict(n.remaps) == {'/clock': f'{namespace}/clock'} for n in nodes)
        plant = next(n for n in nodes if n.executable == 'plant_node')
        overrides = dict(plant.parameters)
        assert overrides['sim.start.base_node'] == start.base_node
        assert overrides['sim.start.other_node'] == start.other_node
        assert overrides['sim.start.other_attached'] == 'true'
        command = plant.command('/bin/true')
        assert f'/clock:={namespace}/clock' in command
        assert f'sim.start.base_node:={start.base_node}' in command
        assert not any('sim.start' in arg for n in nodes if n is not plant
                       for arg in n.command('/bin/true'))


def test_each_walker_walks_the_same_route_moved_with_its_start():
    stances = start_stances(PARAMS, 4)  # rows 1, 2, 3, 0 from column 1
    assert walker_targets(PARAMS, 'n3_1', stances) == ['n3_1', 'n3_2', 'n3_3', 'n3_0']
    # where the moved target is off the truss, the target itself
    assert walker_targets(PARAMS, 'n4_3', stances) == ['n4_3', 'n4_3', 'n4_3', 'n4_2']
    with pytest.raises(UnknownNodeError):
        walker_targets(PARAMS, 'n9_9', stances)


def test_parameters_given_to_the_graph_reach_every_node():
    nodes = walker_graph(PARAMS, record=True, parameters=(('timing.control_rate', '1000.0'),))
    assert all(n.command('/bin/true')[-2:] == ['-p', 'timing.control_rate:=1000.0']
               for n in nodes)


def test_run_all_refuses_a_bad_number_of_walkers(capsys):
    assert run_arguments(['--walkers', '3', '--composed']).walkers == 3
    for bad in ('0', '-1', 'two'):
        with pytest.raises(SystemExit):
            run_arguments(['--walkers', bad])
        assert 'positive number of walkers' in capsys.readouterr().err


@pytest.mark.parametrize('options', [
    {},
    {'sim_time': True, 'record': True, 'bag_path': '/tmp/some/bag'},
    {'namespace': '/walker_2', 'start': StartStance('a', 'n1_2', 'n2_2'),
     'clock_topic': '/walker_2/clock', 'parameters': (('timing.control_rate', '1000.0'),)},
    {'sim_time': True, 'grouped_controllers': True},
])
def test_the_composed_command_describes_the_same_graph(options):
    keywords = {'namespace': '/walker', 'sim_time': False, 'record': False, 'bag_path': None,
                'start': None, 'clock_topic': None, 'parameters': (),
                'grouped_controllers': False, **options}
    command = composed_command(PARAMS, executable='/bin/composed_graph', **keywords)
    assert command[0] == '/bin/composed_graph'
    composed = graph_from_arguments(parse_arguments(command[1:]))
    expected = walker_graph(PARAMS, **keywords)
    assert composed == expected
    assert all(component_of(spec) is COMPONENTS[(spec.package, spec.executable)]
               for spec in composed)


@pytest.mark.parametrize('argv, message', [
    (['--start', 'a,n1_1'], 'GRIPPER,BASE_NODE,OTHER_NODE'),
    (['--start', 'a,,n2_1'], 'GRIPPER,BASE_NODE,OTHER_NODE'),
    (['--param', 'timing.control_rate=1000'], 'NAME:=VALUE'),
    (['--bag-path', '/tmp/bag'], '--bag-path needs --record'),
])
def test_composed_graph_refuses_malformed_options(argv, message, capsys):
    with pytest.raises(SystemExit):
        parse_arguments(argv)
    assert message in capsys.readouterr().err


def test_an_executable_that_cannot_be_composed_is_named():
    with pytest.raises(CompositionError, match='walker_teleop/keyboard cannot be composed'):
        component_of(NodeSpec('walker_teleop', 'keyboard', 'keys', '/walker', str(PARAMS)))


@pytest.mark.integration
def test_the_composed_graph_builds_every_node_with_its_process_arguments(tmp_path):
    """Built in one process, each node has the name and the parameters its process gets."""
    import rclpy
    from ros_test_support import isolated_domain

    start = StartStance('a', 'n1_2', 'n2_2')
    specs = walker_graph(PARAMS, '/walker_2', sim_time=True, record=True,
                         bag_path=tmp_path / 'bag', start=start, clock_topic='/walker_2/clock')
    with isolated_domain() as domain:
        context = rclpy.context.Context()
        rclpy.init(context=context, domain_id=domain)
        graph = None
        try:
            graph = ComposedGraph(specs, context)
            assert [node.get_fully_qualified_name() for _, _, node in graph.nodes] == \
                [spec.full_name for spec in specs]
            for spec, _, node in graph.nodes:
                for name, value in spec.parameters:
                    if name == 'recorder.topics':
                        continue  # a list, checked through the recorder's selection below
                    actual = node.get_parameter(name).value
                    assert str(actual).lower() == value.lower(), (spec.full_name, name)
            plant = graph.node('plant')
            assert plant.get_parameter('sim.start.base_node').value == 'n1_2'
            assert plant.get_parameter('use_sim_time').value is True
            controller = graph.node('controller_b_yaw')
            assert controller.get_parameter('joint_name').value == 'b_yaw_joint'
            # the /clock remap applies to the node's topics, as on its process's command line
            assert controller.resolve_topic_name('/clock') == '/walker_2/clock'
        finally:
            if graph is not None:
                graph.destroy()
            rclpy.try_shutdown(context=context)
    assert (tmp_path / 'bag' / 'metadata.yaml').exists()


@pytest.mark.integration
def test_a_node_that_refuses_to_start_is_named_and_nothing_is_left(tmp_path):
    import rclpy
    from ros_test_support import isolated_domain

    specs = walker_graph(PARAMS, sim_time=True)
    specs[1] = NodeSpec(specs[1].package, specs[1].executable, specs[1].name,
                        specs[1].namespace, specs[1].params_file,
                        (('joint_name', 'elbow_joint'),))
    with isolated_domain() as domain:
        context = rclpy.context.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            with pytest.raises(CompositionError,
                               match=r'/walker/controller_a_yaw refused to start: .*elbow_joint'):
                ComposedGraph(specs, context)
        finally:
            rclpy.try_shutdown(context=context)
