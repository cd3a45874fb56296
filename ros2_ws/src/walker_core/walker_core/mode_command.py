"""Who may command the controllers' mode: their namespace's supervisor, and no one else.

``walker_msgs/ControlMode`` on ``control_mode`` is the supervisor's command to the joint
controllers and the planner. The supervisor checks its interlocks and phase rules before every
mode it sends (OFF only with both grippers attached, a base change only with the chain closed,
nothing during a step but the step's own modes); a command from anyone else would skip them: a
HOLD that changed the base with one gripper free once ran the controllers' relaxation dither
with the chain open and drove the free gripper 13 mm off its hole and into the truss. So every
receiver refuses a command whose ``commander`` is not its namespace's supervisor, or whose base
is not a gripper, and changes nothing. An operator changes the mode through the supervisor
(``hold``, ``resume``, the jogs, ``step``, ``walk_to``).

The ``commander`` field keeps a command typed by hand or sent by mistake out; it is not a
security boundary (a publisher can claim any name; DDS-Security is not available here).
"""

from __future__ import annotations

from walker_core.joint_roles import GRIPPERS

__all__ = ['SUPERVISOR_NODE', 'mode_commander', 'mode_command_refusal']

#: Name of the node, in the robot's namespace, whose mode commands the controllers follow.
SUPERVISOR_NODE = 'supervisor'


def mode_commander(namespace: str) -> str:
    """Return the fully qualified name of the supervisor of ``namespace`` (e.g. ``/walker``)."""
    return f'{namespace.rstrip("/")}/{SUPERVISOR_NODE}'


def mode_command_refusal(commander: str, base_gripper: str, namespace: str) -> str:
    """Say why a mode command received in ``namespace`` is refused ('' when it is not).

    Parameters
    ----------
    commander : str
        The command's ``commander`` field.
    base_gripper : str
        Its ``base_gripper`` field.
    namespace : str
        The receiving node's namespace.
    """
    expected = mode_commander(namespace)
    if commander != expected:
        sender = repr(commander) if commander else 'no commander'
        return (f'control_mode command from {sender} refused: only {expected} commands the '
                f"controllers' mode (an operator holds, resumes, jogs and steps through its "
                f'services and actions)')
    if base_gripper not in GRIPPERS:
        return (f'control_mode command refused: base gripper {base_gripper!r} is not a gripper '
                f'(expected "a" or "b")')
    return ''
