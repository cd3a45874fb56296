"""ROS layer of the parameter schema: declare a section on an rclpy node and guard updates.

The model's sections (``walker_core``) know nothing of ROS; here they meet a node. Every leaf
of a section is declared with its description, unit and range (``ros2 param describe`` shows
them) and with the default from the package's ``config/walker.yaml``, so a node started without
a parameter file still gets the documented values; ``--params-file`` overrides them as usual.
Runtime updates (``ros2 param set``) are validated by building the whole section again: an
invalid update is refused with the reason and nothing changes.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Callable, Mapping

from rcl_interfaces.msg import (
    FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult)
from rclpy.node import Node
from rclpy.parameter import Parameter

from walker_core.parameter_file import default_values
from walker_core.parameter_schema import (
    ParameterError, ParameterSpec, leaf_specs, replace_in_section, section_from_flat)

__all__ = ['declare_section', 'guard_section_updates', 'fix_use_sim_time']


def _descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    descriptor = ParameterDescriptor(description=spec.full_description,
                                     read_only=spec.read_only)
    if spec.minimum is not None and spec.maximum is not None:
        if spec.type is float:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(spec.minimum), to_value=float(spec.maximum), step=0.0)]
        elif spec.type is int:
            descriptor.integer_range = [IntegerRange(
                from_value=int(spec.minimum), to_value=int(spec.maximum), step=1)]
    if spec.type in (tuple[float, ...], tuple[int, ...]) and spec.minimum is not None:
        descriptor.additional_constraints = (
            f'each element in [{spec.minimum:g}, {spec.maximum:g}] {spec.unit}'.strip())
    return descriptor


def _ros_value(spec: ParameterSpec, value: Any) -> Any:
    if spec.type == tuple[float, ...]:
        return [float(v) for v in value]
    if spec.type == tuple[int, ...]:
        return [int(v) for v in value]
    if spec.type == tuple[str, ...]:
        return [str(v) for v in value]
    if spec.type is float:
        return float(value)
    return value


def declare_section(node: Node, section_type: type, prefix: str = '',
                    defaults: Mapping[str, Any] | None = None) -> Any:
    """Declare every parameter of ``section_type`` on ``node`` and return the built section.

    Parameters
    ----------
    node : rclpy.node.Node
        The node to declare on.
    section_type : type
        A parameter section dataclass (see :mod:`walker_core.parameter_schema`).
    prefix : str
        Dotted prefix of the section in the parameter file, e.g. ``'control.'``; ``''`` for
        a top-level section type such as ``WalkerParameters``.
    defaults : mapping, optional
        Flat default values; the default is the installed ``config/walker.yaml``, parsed
        once per process (:func:`walker_core.parameter_file.default_values`).

    Raises
    ------
    ParameterError
        If the values (defaults overridden by the node's parameter file) are invalid; the node
        should refuse to start.
    """
    if defaults is None:
        defaults = default_values()
    specs = leaf_specs(section_type, prefix)
    for spec in specs:
        if spec.name not in defaults:
            raise ParameterError(f'parameter {spec.name!r} has no default value')
        node.declare_parameter(spec.name, _ros_value(spec, defaults[spec.name]),
                               _descriptor(spec))
    flat = {spec.name: node.get_parameter(spec.name).value for spec in specs}
    return section_from_flat(section_type, flat, prefix)


def guard_section_updates(node: Node, section_type: type, prefix: str,
                          current: Callable[[], Any], apply: Callable[[Any], None],
                          check: Callable[[Any], None] | None = None) -> None:
    """Validate runtime updates of a section's parameters as a whole, then apply them.

    Parameters
    ----------
    current : callable
        Returns the section now in force.
    apply : callable
        Receives the new, validated section once the parameters have been set.
    check : callable, optional
        Checks a candidate section against what lies outside it (other sections) and raises
        :class:`ParameterError` to refuse it.
    """
    names = {spec.name for spec in leaf_specs(section_type, prefix)}
    pending: dict[str, Any] = {}

    def validate(parameters: list[Parameter]) -> SetParametersResult:
        updates = {p.name: p.value for p in parameters if p.name in names}
        if not updates:
            return SetParametersResult(successful=True)
        try:
            candidate = replace_in_section(current(), updates, prefix)
            if check is not None:
                check(candidate)
        except ParameterError as error:
            return SetParametersResult(successful=False, reason=str(error))
        pending['section'] = candidate
        return SetParametersResult(successful=True)

    def commit(parameters: list[Parameter]) -> None:
        if any(p.name in names for p in parameters) and 'section' in pending:
            apply(pending.pop('section'))

    node.add_on_set_parameters_callback(validate)
    node.add_post_set_parameters_callback(commit)


def fix_use_sim_time(node: Node) -> None:
    """Refuse a runtime change of ``use_sim_time``, with the reason, on ``node``.

    A node's clock is chosen with the graph's at start (``run_all.py --sim-time``, the plant's
    ``sim.clock_mode``): one node switched alone would stamp and time in another clock than
    its peers' (its timers stopped at /clock's time, or running on the wall clock). Set at
    start (``-p use_sim_time:=true``) it stands.
    """
    def refuse(parameters: list[Parameter]) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name == 'use_sim_time' and parameter.value != \
                    node.get_parameter('use_sim_time').value:
                return SetParametersResult(successful=False, reason=(
                    "use_sim_time is chosen with the graph's clock at start and cannot change "
                    'while the node runs (start the graph with or without --sim-time)'))
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(refuse)
