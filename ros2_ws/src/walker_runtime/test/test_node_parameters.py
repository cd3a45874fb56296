"""Declaring the shared sections on a real rclpy node: descriptors, defaults, guarded updates."""

import dataclasses

import pytest
from rclpy.parameter import Parameter

from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_core.parameter_schema import ParameterError, parameter
from walker_core.robot_parameters import WalkerParameters, load_walker_parameters


@dataclasses.dataclass(frozen=True)
class Band:
    """A writable section with a cross-field rule, standing in for controller gains."""

    low: float = parameter('lower edge', 'm', 0.0, 10.0, read_only=False)
    high: float = parameter('upper edge', 'm', 0.0, 10.0, read_only=False)

    def __post_init__(self):
        if self.low >= self.high:
            raise ParameterError(f'band.low ({self.low}) must be below band.high ({self.high})')


@pytest.fixture
def make_node(rclpy_context):
    from rclpy.node import Node

    nodes = []

    def make(name, overrides=()):
        node = Node(name, context=rclpy_context, parameter_overrides=list(overrides))
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.destroy_node()


def test_declared_parameters_carry_description_range_and_file_defaults(make_node):
    node = make_node('parameter_probe')
    params = declare_section(node, WalkerParameters)
    assert params == load_walker_parameters()
    descriptor = node.describe_parameter('robot.geometry.l2')
    assert 'link' in descriptor.description and '[m]' in descriptor.description
    assert descriptor.read_only
    assert descriptor.floating_point_range[0].from_value == 0.05
    assert node.get_parameter('truss.columns').value == 5


def test_geometry_cannot_change_at_run_time(make_node):
    node = make_node('parameter_probe_ro')
    declare_section(node, WalkerParameters)
    result = node.set_parameters([Parameter('truss.spacing', value=0.8)])[0]
    assert not result.successful
    assert node.get_parameter('truss.spacing').value == 0.9


def test_runtime_updates_are_validated_as_a_whole(make_node):
    node = make_node('parameter_probe_band')
    current = {'band': declare_section(node, Band, 'band.', {'band.low': 1.0, 'band.high': 2.0})}
    guard_section_updates(node, Band, 'band.', lambda: current['band'],
                          lambda section: current.update(band=section))
    refused = node.set_parameters([Parameter('band.low', value=5.0)])[0]
    assert not refused.successful and 'must be below' in refused.reason
    assert node.get_parameter('band.low').value == 1.0 and current['band'].low == 1.0
    out_of_range = node.set_parameters([Parameter('band.high', value=50.0)])[0]
    assert not out_of_range.successful
    accepted = node.set_parameters_atomically([Parameter('band.low', value=3.0),
                                               Parameter('band.high', value=4.0)])
    assert accepted.successful
    assert current['band'] == Band(3.0, 4.0)


@dataclasses.dataclass(frozen=True)
class Gains:
    """A writable section of number lists, as the controllers' per-role gains."""

    bandwidth: tuple[float, ...] = parameter('per-role bandwidth', 'rad/s', 0.0, 10.0,
                                             read_only=False)
    order: tuple[int, ...] = parameter('per-role order', '', 0, 8, read_only=False)


def test_runtime_updates_of_number_lists_are_accepted(make_node):
    node = make_node('parameter_probe_lists')
    current = {'gains': declare_section(node, Gains, 'gains.',
                                        {'gains.bandwidth': [1.0, 2.0], 'gains.order': [4, 2]})}
    guard_section_updates(node, Gains, 'gains.', lambda: current['gains'],
                          lambda section: current.update(gains=section))

    def as_over_the_wire(name, value):
        # The set_parameters service hands number lists over as array.array.
        return Parameter.from_parameter_msg(Parameter(name, value=value).to_parameter_msg())

    assert node.set_parameters([as_over_the_wire('gains.bandwidth', [3.0, 4.0])])[0].successful
    assert node.set_parameters([as_over_the_wire('gains.order', [2, 2])])[0].successful
    assert current['gains'] == Gains((3.0, 4.0), (2, 2))
    refused = node.set_parameters([as_over_the_wire('gains.bandwidth', [30.0, 4.0])])[0]
    assert not refused.successful and 'above the maximum' in refused.reason
    assert current['gains'].bandwidth == (3.0, 4.0)


def test_out_of_range_override_refuses_to_start(make_node):
    from rclpy.exceptions import InvalidParameterValueException

    node = make_node('parameter_probe_bad', [Parameter('robot.geometry.l2', value=-1.0)])
    with pytest.raises(InvalidParameterValueException):
        declare_section(node, WalkerParameters)


def test_cross_field_violation_refuses_to_start(make_node):
    node = make_node('parameter_probe_cross', [Parameter('truss.spacing', value=1.5)])
    with pytest.raises(ParameterError, match='reach'):
        declare_section(node, WalkerParameters)


def test_use_sim_time_stands_as_set_at_start(make_node):
    from walker_runtime.node_parameters import fix_use_sim_time

    node = make_node('clock_probe', [Parameter('use_sim_time', value=True)])
    fix_use_sim_time(node)
    result = node.set_parameters([Parameter('use_sim_time', value=False)])[0]
    assert not result.successful and 'cannot change while the node runs' in result.reason
    assert node.get_parameter('use_sim_time').value is True
    # setting it to what it is changes nothing and is no error
    assert node.set_parameters([Parameter('use_sim_time', value=True)])[0].successful
