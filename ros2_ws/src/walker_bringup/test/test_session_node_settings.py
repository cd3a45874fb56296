"""A session's graph with nodes of the caller's own, remaps and per-node parameters.

What a test harness (the fault tests' lossy link, their longer timeouts) gives the session
instead of building the graph itself; and the session leaving this process's signal handlers
and DDS profile as it found them.
"""

import os
import signal

import pytest

from walker_bringup.graph import NodeSpec
from walker_bringup.graph_walkers import describe_walkers, launch
from walker_bringup.session import Arrangement, SessionError, SessionOptions, WalkSession
from walker_bringup.transport import PROFILES_VARIABLE
from walker_config.core.configuration import load_configuration

ENV = {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
TIMEOUT = ('controller*', 'control.setpoint_timeout', '2.0')
REMAP = ('controller_vertex', 'controllers/vertex_joint/setpoint', 'lossy')


class _Group:
    """Records what a launch starts, and with which command."""

    def __init__(self):
        self.started = []

    def start(self, spec, command=None):
        self.started.append((spec.name, command))


def _link(configuration) -> NodeSpec:
    return NodeSpec('walker_bringup', 'lossy_link', 'lossy_link', '/walker',
                    str(configuration.path), parameters=(('seed', '5'),))


def test_extra_nodes_remaps_and_node_parameters_reach_the_nodes_they_name(tmp_path):
    configuration = load_configuration()
    options = SessionOptions(sim_time=True, out=tmp_path, node_parameters=(TIMEOUT,),
                             remaps=(REMAP,), extra_nodes=(_link(configuration),))
    walker = describe_walkers(options, configuration, tmp_path, ENV)[0]
    nodes = {spec.name: spec for spec in walker.nodes}
    assert nodes['lossy_link'].parameters == (('seed', '5'),)
    controllers = [name for name in nodes if name.startswith('controller')]
    assert len(controllers) == 5
    for name, spec in nodes.items():
        given = ('control.setpoint_timeout', '2.0') in spec.parameters
        assert given == (name in controllers), name
    # after the file's and every node's overrides: the later -p wins
    assert nodes['controller_vertex'].parameters[-1] == ('control.setpoint_timeout', '2.0')
    assert [n for n, s in nodes.items() if REMAP[1:] in s.remaps] == ['controller_vertex']
    assert 'controllers/vertex_joint/setpoint:=lossy' in \
        nodes['controller_vertex'].ros_arguments()
    walker.group = _Group()
    launch(walker, options, configuration.path)
    assert ('lossy_link', None) in walker.group.started


@pytest.mark.parametrize('arrangement', [Arrangement.COMPOSED, Arrangement.COMPOSED_LOOP])
def test_extra_nodes_run_beside_a_composed_graph(tmp_path, arrangement):
    configuration = load_configuration()
    options = SessionOptions(arrangement=arrangement, sim_time=True, out=tmp_path,
                             extra_nodes=(_link(configuration),))
    walker = describe_walkers(options, configuration, tmp_path, ENV)[0]
    walker.group = _Group()
    launch(walker, options, configuration.path)
    assert ('lossy_link', None) in walker.group.started


@pytest.mark.parametrize('changes, named', [
    ({'node_parameters': (('planer', 'x', '1'),)}, "node_parameters: 'planer' names no node"),
    ({'remaps': (('camera*', 'a', 'b'),)}, "remaps: 'camera\\*' names no node"),
    ({'extra_nodes': 'planner'}, "extra node 'planner': the graph has a node of that name")])
def test_a_node_setting_that_fits_no_node_is_refused_before_anything_starts(tmp_path, changes,
                                                                          named):
    configuration = load_configuration()
    if changes.get('extra_nodes') == 'planner':
        changes = {'extra_nodes': (NodeSpec('walker_planner', 'planner_node', 'planner',
                                            '/walker', str(configuration.path)),)}
    session = WalkSession(configuration, SessionOptions(out=tmp_path, quiet=True, **changes))
    with pytest.raises(SessionError, match=named) as error:
        session.check_target('n1_2')
    assert error.value.code == 2
    assert not (tmp_path / 'logs').exists()


@pytest.mark.parametrize('changes, said', [
    ({'arrangement': Arrangement.HEADLESS, 'remaps': (REMAP,)}, 'runs no graph: leave remaps'),
    ({'arrangement': Arrangement.COMPOSED, 'node_parameters': (TIMEOUT,)},
     'the composed arrangement runs nodes in one process'),
    ({'arrangement': Arrangement.COMPOSED_LOOP, 'remaps': (REMAP,)},
     'the composed_loop arrangement runs nodes in one process'),
    ({'node_parameters': (('controller*', 'control.setpoint_timeout'),)},
     r'entries are \(node, name, value\) strings'),
    ({'remaps': (('controller_vertex', '', 'b'),)}, r'entries are \(node, name, value\)'),
    ({'extra_nodes': ('lossy_link',)}, 'extra_nodes are NodeSpecs'),
    ({'walkers': 2, 'extra_nodes': (NodeSpec('p', 'e', 'n', '/walker', 'f'),)},
     'extra_nodes are for one walker')])
def test_node_settings_a_session_cannot_apply_are_refused(changes, said):
    with pytest.raises(SessionError, match=said) as error:
        SessionOptions(**changes)
    assert error.value.code == 2


@pytest.mark.parametrize('handle_signals', [True, False])
def test_a_session_gives_back_the_signal_handlers_and_the_dds_profile_it_found(
        tmp_path, monkeypatch, handle_signals):
    import walker_bringup.graph_session as graph_session
    from walker_bringup.graph_client import GraphNotReadyError

    class Context:
        def try_shutdown(self):
            pass

    seen = {}

    def launch_nothing(*_args):  # what the graph's processes would see, then no graph
        seen['handler'] = signal.getsignal(signal.SIGINT)
        seen['profile'] = os.environ.get(PROFILES_VARIABLE)
        raise GraphNotReadyError('no graph in this test')

    monkeypatch.delenv(PROFILES_VARIABLE, raising=False)
    monkeypatch.setattr(graph_session, 'init_context', Context)
    monkeypatch.setattr(graph_session, 'namespaces_in_use', lambda *_args: '')
    monkeypatch.setattr(graph_session, 'launch', launch_nothing)
    before = signal.getsignal(signal.SIGINT)
    session = WalkSession(load_configuration(), SessionOptions(
        out=tmp_path, quiet=True, transport='udp', handle_signals=handle_signals))
    with pytest.raises(SessionError) as error:
        session.start()
    assert error.value.code == 3
    assert (seen['handler'] is not before) == handle_signals
    assert seen['profile'] and seen['profile'].endswith('.xml')  # the client reached over UDP
    assert session.stop() == 0
    assert signal.getsignal(signal.SIGINT) is before
    assert PROFILES_VARIABLE not in os.environ
    assert session.exit_codes == {}
