"""Several walkers' graphs, and the composed graph built from the same descriptions."""

from pathlib import Path

import pytest

from walker_bringup.composed_process import (
    composed_command, graph_from_arguments, parse_arguments)
from walker_bringup.composition import (
    COMPONENTS, LOOP_NODES, ComposedGraph, CompositionError, component_of)
from walker_bringup.graph import (
    SURVEY_FILE_PARAMETER, NodeSpec, StartStance, several_walkers, start_stances, walker_graph,
    walker_namespace, walker_targets)
from walker_config.core.configuration import load_configuration
from walker_bringup.run import parse_arguments as run_arguments
from walker_core.robot_parameters import default_parameter_file
from walker_core.truss import Truss, UnknownNodeError

PARAMS = Path(default_parameter_file()).resolve()


@pytest.fixture(scope='module')
def configuration():
    return load_configuration(PARAMS)


def test_walker_namespaces():
    assert [walker_namespace(i) for i in (1, 2, 4)] == ['/walker', '/walker_2', '/walker_4']
    for bad in (0, -1, 1.0, True, '2'):
        with pytest.raises(ValueError, match='walker index'):
            walker_namespace(bad)


@pytest.mark.parametrize('count', [1, 2, 4, 8])
def test_start_stances_are_distinct_neighbouring_nodes_on_the_truss(configuration, count):
    truss = Truss.from_parameters(configuration.walker)
    stances = start_stances(configuration, count)
    assert len(stances) == count
    # the first walker starts where the parameter file says
    assert stances[0] == StartStance('a', 'n1_1', 'n2_1')
    nodes = [n for s in stances for n in (s.base_node, s.other_node)]
    assert len(set(nodes)) == len(nodes)
    for stance in stances:
        assert stance.other_node in truss.neighbors(stance.base_node)


def test_more_walkers_than_the_truss_holds_or_no_walker_is_refused(configuration):
    with pytest.raises(ValueError, match='room for 8 walkers'):
        start_stances(configuration, 9)
    for bad in (0, -2, 2.5, True):
        with pytest.raises(ValueError, match='positive integer'):
            start_stances(configuration, bad)


def test_several_walkers_get_their_namespace_start_and_clock(configuration):
    graphs = several_walkers(configuration, 3, sim_time=True)
    assert [ns for ns, _, _ in graphs] == ['/walker', '/walker_2', '/walker_3']
    # the first walker's graph is exactly the single walker's
    assert graphs[0][2] == walker_graph(PARAMS, '/walker', sim_time=True)
    for namespace, start, nodes in graphs[1:]:
        assert all(n.namespace == namespace for n in nodes)
        assert all(dict(n.remaps) == {'/clock': f'{namespace}/clock', '/tf': f'{namespace}/tf',
                                      '/tf_static': f'{namespace}/tf_static'} for n in nodes)
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


def test_each_walkers_supervisor_alone_keeps_its_own_truss_survey(configuration, tmp_path):
    graphs = several_walkers(configuration, 2, sim_time=True, state_dir=tmp_path)
    kept = {}
    for namespace, _, nodes in graphs:
        for node in nodes:
            survey = dict(node.parameters).get(SURVEY_FILE_PARAMETER)
            assert (survey is not None) == (node.executable == 'supervisor_node'), node.name
            if survey is not None:
                kept[namespace] = survey
    assert kept == {'/walker': str(tmp_path / 'truss_survey.yaml'),
                    '/walker_2': str(tmp_path / 'truss_survey_walker_2.yaml')}


def test_each_walker_walks_the_same_route_moved_with_its_start(configuration):
    stances = start_stances(configuration, 4)  # rows 1, 2, 3, 0 from column 1
    assert walker_targets(configuration, 'n3_1', stances) == ['n3_1', 'n3_2', 'n3_3', 'n3_0']
    # where the moved target is off the truss, the target itself
    assert walker_targets(configuration, 'n4_3', stances) == ['n4_3', 'n4_3', 'n4_3', 'n4_2']
    with pytest.raises(UnknownNodeError):
        walker_targets(configuration, 'n9_9', stances)


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
    {'sim_time': True, 'grouped_controllers': True, 'only': LOOP_NODES},
    {'sim_time': True, 'record': True, 'bag_path': '/tmp/some/bag',
     'plant_state_file': '/tmp/some/plant_state.json'},
    {'sim_time': True, 'survey_file': '/tmp/some/truss_survey.yaml'},
])
def test_the_composed_command_describes_the_same_graph(options):
    keywords = {'namespace': '/walker', 'sim_time': False, 'record': False, 'bag_path': None,
                'start': None, 'clock_topic': None, 'parameters': (),
                'grouped_controllers': False, **options}
    only = keywords.pop('only', None)
    command = composed_command(PARAMS, executable='/bin/composed_graph', only=only, **keywords)
    assert command[0] == '/bin/composed_graph'
    composed = graph_from_arguments(parse_arguments(command[1:]))
    expected = [spec for spec in walker_graph(PARAMS, **keywords)
                if only is None or spec.name in only]
    assert [spec.name for spec in composed] == list(only or [s.name for s in expected])
    assert composed == expected
    assert all(component_of(spec) is COMPONENTS[(spec.package, spec.executable)]
               for spec in composed)


@pytest.mark.parametrize('argv, message', [
    (['--start', 'a,n1_1'], 'GRIPPER,BASE_NODE,OTHER_NODE'),
    (['--start', 'a,,n2_1'], 'GRIPPER,BASE_NODE,OTHER_NODE'),
    (['--param', 'timing.control_rate=1000'], 'NAME:=VALUE'),
    (['--bag-path', '/tmp/bag'], '--bag-path needs --record'),
    (['--append-bag'], '--append-bag needs --record'),
])
def test_composed_graph_refuses_malformed_options(argv, message, capsys):
    with pytest.raises(SystemExit):
        parse_arguments(argv)
    assert message in capsys.readouterr().err


def test_a_composed_graph_that_appends_continues_its_recorders_bag_and_nothing_else():
    command = composed_command(PARAMS, sim_time=True, record=True, bag_path='/tmp/some/bag',
                               executable='/bin/composed_graph')
    plain = graph_from_arguments(parse_arguments(command[1:]))
    appended = graph_from_arguments(parse_arguments([*command[1:], '--append-bag']))
    assert [s.name for s in appended] == [s.name for s in plain]
    for before, after in zip(plain, appended, strict=True):
        added = set(after.parameters) - set(before.parameters)
        assert added == ({('recorder.append', 'true')} if before.name == 'recorder' else set())


def test_composing_a_node_the_graph_has_not_is_refused_with_the_names_it_has():
    args = parse_arguments(['--sim-time', '--only', 'plant,controllers'])  # not grouped
    with pytest.raises(CompositionError, match=r'no node controllers \(it has .*controller_a_yaw'):
        graph_from_arguments(args)


def test_run_all_composes_the_loop_with_the_controllers_grouped_or_the_whole_graph(capsys):
    args = run_arguments(['--composed-loop'])
    assert args.composed_loop and args.grouped_controllers and not args.composed
    with pytest.raises(SystemExit):
        run_arguments(['--composed-loop', '--composed'])
    assert 'choose one' in capsys.readouterr().err


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


@pytest.mark.integration
def test_the_loop_by_call_steps_sim_time_and_still_serves_the_plants_timers():
    """Plant and grouped controllers composed in sim time: they exchange by call, not DDS."""
    import threading
    import time

    import rclpy
    from rclpy.node import Node
    from ros_test_support import isolated_domain
    from sensor_msgs.msg import JointState
    from walker_msgs.msg import GripperStates

    from walker_runtime.qos import COMMAND_QOS, LATCHED_QOS

    specs = [spec for spec in walker_graph(PARAMS, sim_time=True, grouped_controllers=True)
             if spec.name in LOOP_NODES]
    with isolated_domain() as domain:
        context = rclpy.context.Context()
        rclpy.init(context=context, domain_id=domain)
        graph = listener = None
        try:
            graph = ComposedGraph(specs, context)
            assert graph.loop_by_call
            listener = Node('loop_listener', context=context)
            heard = {'efforts': 0, 'heartbeats': 0}
            listener.create_subscription(
                JointState, '/walker/effort_commands',
                lambda _: heard.__setitem__('efforts', heard['efforts'] + 1), COMMAND_QOS)
            listener.create_subscription(
                GripperStates, '/walker/gripper_states',
                lambda _: heard.__setitem__('heartbeats', heard['heartbeats'] + 1), LATCHED_QOS)
            stop = threading.Event()
            executor = rclpy.executors.SingleThreadedExecutor(context=context)
            executor.add_node(listener)

            def listen():
                while not stop.is_set():
                    executor.spin_once(timeout_sec=0.05)

            spinner = threading.Thread(target=listen)
            spinner.start()
            seconds = 3.0
            start = time.monotonic()
            graph.spin(lambda: time.monotonic() - start > seconds)
            stop.set()
            spinner.join()
            plant = graph.node('plant')
            assert plant.plant.time > 1.0  # [s] simulated: the loop ran (holding)
            assert plant.lockstep.timeouts == 0
            assert heard['efforts'] == 0  # nothing went through DDS
            # the 10 Hz heartbeat (steady clock) kept coming while the loop ran flat out
            assert heard['heartbeats'] >= 0.5 * seconds * 10, heard
            executor.remove_node(listener)
        finally:
            if listener is not None:
                listener.destroy_node()
            if graph is not None:
                graph.destroy()
            rclpy.try_shutdown(context=context)
