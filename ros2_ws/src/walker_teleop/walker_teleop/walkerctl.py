"""walkerctl: drive a running walker from the command line, without the ROS 2 CLI.

Every command is one of the supervisor's topics, services or actions, the same an operator with
a full ROS 2 install reaches with ``ros2 service call`` or ``ros2 action send_goal`` (each
subcommand's ``--help`` shows that command line). ``walkerctl --help`` lists the commands.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import textwrap
import time

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES

__all__ = ['main', 'build_parser', 'EXIT_OK', 'EXIT_REFUSED', 'EXIT_USAGE', 'EXIT_NO_GRAPH',
           'EXIT_INTERRUPTED']

EXIT_OK = 0  # the command was carried out
EXIT_REFUSED = 1  # refused or failed: the reason is printed
EXIT_USAGE = 2  # bad arguments (argparse)
EXIT_NO_GRAPH = 3  # the graph, or the server the command needs, did not answer
EXIT_INTERRUPTED = 130  # Ctrl-C
MAX_DOMAIN_ID = 232  # the largest ROS domain id DDS maps to valid ports

_DESCRIPTION = """\
Drive a running walker: show its state, hold and resume, step or walk across the truss, jog a
joint or the free gripper, unscrew or screw in a gripper. Each command is a service or action of
the walker's supervisor (in --namespace), so it is refused, with the reason, in the wrong phase
or out of limits; nothing moves then. Units are SI: rad, rad/s, m, m/s."""

_EPILOG = """\
examples:
  walkerctl status
  walkerctl unscrew b                 # b free, a holds the walker (and is the base)
  walkerctl jog-tip 0 0 0.03          # lift gripper b 30 mm straight out of its hole
  walkerctl jog-joint b_yaw_joint -0.1
  walkerctl screw-in b
  walkerctl walk-to n4_3              # progress on stderr; Ctrl-C cancels after the step
  walkerctl --namespace /walker2 hold

Start a graph to drive with: python3 scripts/run_all.py --serve [--sim-time]

exit codes: 0 done, 1 refused or failed (the reason is printed), 2 bad arguments,
  3 the graph did not answer (or the supervisor died or was started again during a goal),
  130 interrupted
environment: ROS_DOMAIN_ID selects the walker's domain (--domain-id overrides it);
  ROS_AUTOMATIC_DISCOVERY_RANGE is set to LOCALHOST unless already set, so discovery stays on
  this machine."""

# (name, help, description, epilog) of each subcommand; the epilog shows the ros2 equivalent.
_NS = '/walker'
_COMMANDS = {
    'status': (
        'show the phase, the base, the grippers and the joint angles',
        "Show the step phase, the controllers' mode, each gripper (and, for a free gripper, "
        'where the nearest hole is in its own frame: the jog-tip that would bring it there) '
        'and the joint angles.',
        f'ros2 equivalent:\n  ros2 topic echo --once {_NS}/phase\n  ros2 topic echo --once '
        f'{_NS}/gripper_states\n  ros2 topic echo --once {_NS}/joint_states'),
    'hold': (
        'stop any motion and hold (SAFE_HOLD)',
        'Stop the step, walk or jog under way: trajectories stop, the controllers hold, the '
        'grippers stay as they are. The phase becomes SAFE_HOLD until resume.',
        f'ros2 equivalent:\n  ros2 service call {_NS}/hold std_srvs/srv/Trigger'),
    'resume': (
        'leave SAFE_HOLD (both grippers attached)',
        'Leave SAFE_HOLD for IDLE; refused unless both grippers are attached.',
        f'ros2 equivalent:\n  ros2 service call {_NS}/resume std_srvs/srv/Trigger'),
    'step': (
        'take one step to a neighbouring node',
        "Move the free end to a node next to the base gripper's node and screw it in; it "
        'becomes the base. Needs both grippers attached. A progress line goes to stderr; '
        'Ctrl-C cancels (the step under way finishes), twice stops waiting.',
        f'example:\n  walkerctl step n2_1\n'
        f'ros2 equivalent:\n  ros2 action send_goal --feedback {_NS}/step '
        f'walker_msgs/action/Step "{{target_node: n2_1}}"'),
    'walk-to': (
        'walk to any node, step by step',
        'Plan a route of steps to the target node and take them. Needs both grippers '
        'attached. A progress line goes to stderr; Ctrl-C cancels the walk (the step under way '
        'finishes, so the walker ends with both grippers attached), twice stops waiting.',
        f'example:\n  walkerctl walk-to n4_3\n'
        f'ros2 equivalent:\n  ros2 action send_goal --feedback {_NS}/walk_to '
        f'walker_msgs/action/WalkTo "{{target_node: n4_3}}"'),
    'jog-joint': (
        'move one joint by a relative angle',
        'Move one joint by DELTA rad from where it is (minimum-jerk, FINE mode), then hold. '
        'Needs exactly one gripper attached and nothing else under way; refused beyond the '
        "joint's limits, teleop.max_joint_jog, teleop.max_joint_speed, or when the free "
        'gripper would go into the truss or move sideways in a hole. Answers when the joints '
        'have settled; Ctrl-C asks the supervisor to hold (which stops the jog).',
        'example:\n  walkerctl jog-joint b_pitch_joint -0.05 --speed 0.05\n'
        f'ros2 equivalent:\n  ros2 service call {_NS}/jog_joint walker_msgs/srv/JogJoint '
        '"{joint_name: b_pitch_joint, delta: -0.05, max_velocity: 0.05}"'),
    'jog-tip': (
        'move the free gripper along a straight line in its own frame',
        "Move the free gripper's contact point by (DX, DY, DZ) m in the gripper's own frame "
        '(z along its axis away from the truss, x and y fixed to the gripper, as on '
        'gripper_<g>_pose), keeping it vertical, at a constant speed (FINE mode), then hold. '
        'Needs exactly one gripper attached; refused when longer than teleop.max_tip_jog, '
        'faster than teleop.max_tip_speed, out of reach, into the truss, or sideways within '
        'teleop.clearance of the surface (leave a hole straight up). Answers when the joints '
        'have settled; Ctrl-C asks the supervisor to hold.',
        'example:\n  walkerctl jog-tip 0.01 -0.02 0\n'
        f'ros2 equivalent:\n  ros2 service call {_NS}/jog_tip walker_msgs/srv/JogTip '
        '"{delta: [0.01, -0.02, 0.0], max_velocity: 0.0}"'),
    'unscrew': (
        'unscrew a gripper (the other must be attached)',
        'Unscrew a gripper; refused unless the other gripper is attached (the walker never '
        'lets go of the truss) and nothing else is under way. The attached gripper becomes '
        'the base. Answers when the gripper is free.',
        'example:\n  walkerctl unscrew b\n'
        f'ros2 equivalent (command 2 = UNSCREW):\n  ros2 service call {_NS}/operate_gripper '
        'walker_msgs/srv/GripperCommand "{gripper: b, command: 2}"'),
    'screw-in': (
        'screw a free gripper into the hole under it',
        'Screw a free (or jammed) gripper into the hole under it. The plant jams it when it is '
        'not within the insertion tolerance of a hole (2 mm, 2 deg): the answer says by how '
        'much it missed. Answers when the gripper is attached.',
        'example:\n  walkerctl screw-in b\n'
        f'ros2 equivalent (command 1 = SCREW_IN):\n  ros2 service call {_NS}/operate_gripper '
        'walker_msgs/srv/GripperCommand "{gripper: b, command: 1}"'),
}


def _number(text: str) -> float:
    """Read a finite number (argparse type): NaN and infinities never reach the graph."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'not a number: {text!r}') from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f'must be a finite number, got {text!r}')
    return value


def _speed(text: str) -> float:
    """Read a speed (argparse type): finite, not negative; 0 is the parameter file's default."""
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f'must not be negative, got {text!r} (0: the default)')
    return value


def _domain(text: str) -> int:
    """Read a ROS domain id (argparse type): 0 to 232, the ids DDS maps to ports."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'not a whole number: {text!r}') from None
    if not 0 <= value <= MAX_DOMAIN_ID:
        raise argparse.ArgumentTypeError(f'must be between 0 and {MAX_DOMAIN_ID}, got {value}')
    return value


def _positive(text: str) -> float:
    """Read a positive number of seconds (argparse type)."""
    value = _number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f'must be a positive number of seconds, got {text!r}')
    return value


def build_parser() -> argparse.ArgumentParser:
    """Build the command line of walkerctl."""
    parser = argparse.ArgumentParser(
        prog='walkerctl', description=_DESCRIPTION, epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--namespace', default=_NS,
                        help="the robot's namespace (default: %(default)s)")
    parser.add_argument('--domain-id', type=_domain, default=None, metavar='ID',
                        help='ROS domain of the walker (default: $ROS_DOMAIN_ID, else 0)')
    parser.add_argument('--timeout', type=_positive, default=10.0, metavar='S',
                        help='seconds to wait for the graph to be discovered and for answers '
                             'that involve no motion (default: %(default)g); motions are '
                             'waited for until they end')
    commands = parser.add_subparsers(dest='command', metavar='COMMAND', required=True,
                                     title='commands')
    sub = {}
    for name, (summary, description, epilog) in _COMMANDS.items():
        sub[name] = commands.add_parser(
            name, help=summary, description=textwrap.fill(description, 95), epilog=epilog,
            formatter_class=argparse.RawDescriptionHelpFormatter)
    sub['status'].add_argument('--params-file', default=None, metavar='FILE',
                               help='parameter file with the truss layout (default: the '
                                    'installed walker.yaml)')
    for name in ('step', 'walk-to'):
        sub[name].add_argument('node', metavar='NODE', help='target truss node, e.g. n2_1')
        sub[name].add_argument('-q', '--quiet', action='store_true',
                               help='no progress line, only the result')
    sub['jog-joint'].add_argument('joint', metavar='JOINT', choices=PHYSICAL_JOINT_NAMES,
                                  help='physical joint: ' + ', '.join(PHYSICAL_JOINT_NAMES))
    sub['jog-joint'].add_argument('delta', metavar='DELTA', type=_number,
                                  help='angle to move by [rad], relative to where it is')
    sub['jog-joint'].add_argument('--speed', type=_speed, default=0.0, metavar='RAD_PER_S',
                                  help='peak joint speed [rad/s] (default: teleop.joint_speed)')
    for axis in ('dx', 'dy', 'dz'):
        sub['jog-tip'].add_argument(axis, metavar=axis.upper(), type=_number,
                                    help=f"{axis[1]} displacement [m] in the gripper's frame")
    sub['jog-tip'].add_argument('--speed', type=_speed, default=0.0, metavar='M_PER_S',
                                help='speed along the line [m/s] (default: teleop.tip_speed)')
    for name in ('unscrew', 'screw-in'):
        sub[name].add_argument('gripper', metavar='GRIPPER', choices=GRIPPERS,
                               help='"a" or "b"')
    return parser


# ---------------------------------------------------------------------- the commands
def _answer(response) -> int:
    print(response.message or 'done')
    return EXIT_OK if response.success else EXIT_REFUSED


def _status(client, args) -> int:
    from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
    from walker_core.truss import Truss
    from walker_teleop.core.status import format_status

    # The truss layout alone, to name the nearest hole: walkerctl runs on an operator's machine
    # without the plant, controllers or planner (package.xml), so not through the configuration
    # loader, which needs every package's section; the running graph's loader checked the file.
    truss = Truss.from_parameters(load_walker_parameters(
        args.params_file or default_parameter_file()))
    view, missing = client.status()
    if len(missing) == 5:
        print(f'walkerctl: nothing received from {args.namespace} within {args.timeout:g} s: '
              f'{client.where()}', file=sys.stderr)
        return EXIT_NO_GRAPH
    print(format_status(view, truss))
    if missing:
        print(f'walkerctl: not received within {args.timeout:g} s: {", ".join(missing)}',
              file=sys.stderr)
        return EXIT_NO_GRAPH
    return EXIT_OK


def _trigger(client, args) -> int:
    return _answer(client.trigger(args.command))


def _goal(client, args) -> int:
    from walker_core.progress import ProgressLine, step_progress, walk_progress

    progress = ProgressLine(quiet=args.quiet)
    started = time.monotonic()
    action = 'walk_to' if args.command == 'walk-to' else 'step'

    def on_feedback(feedback) -> None:
        elapsed = time.monotonic() - started
        if action == 'walk_to':
            progress.update(walk_progress(feedback.step_index, feedback.step_count,
                                          feedback.phase, feedback.from_node, feedback.to_node,
                                          feedback.tip_position_error, elapsed),
                            key=(feedback.step_index, feedback.phase))
        else:
            progress.update(step_progress(args.node, feedback.phase,
                                          feedback.tip_position_error, elapsed),
                            key=feedback.phase)

    def on_cancel() -> None:
        progress.end()
        print('walkerctl: cancelling: the step under way finishes, then the walker stops with '
              'both grippers attached (Ctrl-C again to stop waiting)', file=sys.stderr)

    from walker_teleop.client import GoalRejectedError

    try:
        status, result = client.run_goal(action, args.node, on_feedback, on_cancel)
    except GoalRejectedError as rejection:
        print(f'{args.command} {args.node} refused: {rejection.reason}')
        return EXIT_REFUSED
    finally:
        progress.end()  # no progress line is left standing, whatever ends the wait
    if result.success:
        if action == 'walk_to':
            print(f'reached {args.node} in {result.steps_taken} steps, {result.duration:.1f} s '
                  f'of walking: ' + ' -> '.join(result.path))
        else:
            print(f'stepped to {args.node} in {result.duration:.1f} s; gripper '
                  f'{result.base_gripper} is the base at {result.base_node}')
        return EXIT_OK
    print(f'{args.command} {args.node} did not succeed: {result.message or "no reason given"}')
    return EXIT_REFUSED


def _jog_joint(client, args) -> int:
    return _answer(client.jog_joint(args.joint, args.delta, args.speed))


def _jog_tip(client, args) -> int:
    return _answer(client.jog_tip((args.dx, args.dy, args.dz), args.speed))


def _gripper(client, args) -> int:
    from walker_msgs.srv import GripperCommand

    command = (GripperCommand.Request.UNSCREW if args.command == 'unscrew'
               else GripperCommand.Request.SCREW_IN)
    return _answer(client.operate_gripper(args.gripper, command))


_RUN = {'status': _status, 'hold': _trigger, 'resume': _trigger, 'step': _goal,
        'walk-to': _goal, 'jog-joint': _jog_joint, 'jog-tip': _jog_tip, 'unscrew': _gripper,
        'screw-in': _gripper}


def main(argv: list[str] | None = None) -> int:
    """Run walkerctl; return its exit code."""
    args = build_parser().parse_args(argv)
    # DDS discovery stays on this machine unless the operator chose otherwise.
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from walker_teleop.client import CommandInterruptedError, GraphUnavailableError, TeleopClient

    context = rclpy.context.Context()
    # Ctrl-C reaches walkerctl as KeyboardInterrupt, with the context still up to cancel.
    if args.domain_id is not None:
        os.environ['ROS_DOMAIN_ID'] = str(args.domain_id)  # what the messages report
    rclpy.init(context=context, domain_id=args.domain_id,
               signal_handler_options=SignalHandlerOptions.NO)
    client = None
    try:
        client = TeleopClient(args.namespace, context, args.timeout)
        return _RUN[args.command](client, args)
    except GraphUnavailableError as error:
        print(f'walkerctl: {error}', file=sys.stderr)
        return EXIT_NO_GRAPH
    except (CommandInterruptedError, KeyboardInterrupt):
        print('walkerctl: interrupted', file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if client is not None:
            client.close()
        context.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
