"""The one ``main()`` of every walker node process: start, spin, stop, and the same exit codes.

Every node executable's ``main`` is a call of :func:`run_node`, which has the shape of the
Jazzy examples (``try`` / ``except (KeyboardInterrupt, ExternalShutdownException)`` /
``finally: destroy_node(); rclpy.try_shutdown()``) around the walker's own start-up
(:func:`~walker_runtime.spinning.init_node_process`: SIGINT and SIGTERM stop the spinning
between callbacks) and spinning (:func:`~walker_runtime.spinning.spin_nodes`).

Exit codes, the same for every node process:

=====  ==========================================================================================
``0``  stopped as asked: SIGINT, SIGTERM or Ctrl-C, or the context shut down
``1``  failed while running: an error nobody expected (Python prints its traceback)
``2``  refused to start: a parameter file that cannot be parsed, an invalid or refused
       parameter, an invalid argument; one line on stderr says which and why, no traceback
=====  ==========================================================================================

A refusal is an error raised while the process starts (by ``rclpy.init`` parsing the
arguments, or while the node is built): a ``ValueError`` (the walker's own errors, such as
``walker_core.parameter_schema.ParameterError``, subclass it), one of rclpy's
``ParameterException`` or ``NameValidationException``, or rcl refusing the command line.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from typing import TypeVar

import rclpy
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node

from walker_runtime.node_parameters import fix_use_sim_time
from walker_runtime.spinning import StopSignals, init_node_process, spin_nodes

__all__ = ['EXIT_OK', 'EXIT_FAILED', 'EXIT_REFUSED', 'REFUSALS', 'run_node', 'refusal_line']

#: Stopped as asked (a signal, or the context shut down).
EXIT_OK = 0
#: Failed while running (an unexpected error; its traceback is on stderr).
EXIT_FAILED = 1
#: Refused to start: a bad parameter file, an invalid parameter or argument (one line).
EXIT_REFUSED = 2
#: The errors that, raised while a node is built, are a refusal to start.
REFUSALS = (ValueError, ParameterException, NameValidationException)

_NodeT = TypeVar('_NodeT', bound=Node)
# rcl's messages end with the C source locations of the failure: nothing a user can act on
_SOURCE_LOCATION = re.compile(r',? at /\S+?\.c:\d+')


def refusal_line(name: str, error: BaseException) -> str:
    """Return the one line that says why ``name`` refuses to start (no traceback, no newline)."""
    reason = ' '.join(_SOURCE_LOCATION.sub('', str(error)).split()) or type(error).__name__
    return f'[{name}] refusing to start: {reason}'


def _refuse(name: str, error: BaseException) -> int:
    print(refusal_line(name, error), file=sys.stderr, flush=True)
    return EXIT_REFUSED


def run_node(make_node: Callable[[], _NodeT], name: str, args: list[str] | None = None, *,
             start: Callable[[_NodeT], object] | None = None,
             executor: Callable[[], Executor] | None = None,
             spin: Callable[[_NodeT, StopSignals], None] | None = None,
             before_destroy: Callable[[_NodeT], None] | None = None) -> int:
    """Run one node in this process until it is asked to stop; return the exit code.

    Parameters
    ----------
    make_node : callable
        Builds the node (its constructor): a :data:`REFUSALS` error raised here is a refusal.
    name : str
        The node's name, for the refusal line (``[name] refusing to start: ...``).
    args : list of str, optional
        The command line for ``rclpy.init`` (default: ``sys.argv``).
    start : callable, optional
        Called with the node once it is built, before it spins (start a helper thread, ask for
        real-time scheduling); a :data:`REFUSALS` error raised here is a refusal too.
    executor : callable, optional
        Makes the executor to spin with (default: :func:`~walker_runtime.spinning.make_executor`).
    spin : callable, optional
        Spins the node instead of :func:`~walker_runtime.spinning.spin_nodes`, called with the
        node and the :class:`~walker_runtime.spinning.StopSignals` it must check.
    before_destroy : callable, optional
        Called with the node before it is destroyed, whatever ended the spinning (close a bag,
        log a count).

    Returns
    -------
    int
        :data:`EXIT_OK` or :data:`EXIT_REFUSED`; an unexpected error propagates (exit code 1).
    """
    try:
        stop = init_node_process(args)
    except _rclpy.RCLError as error:  # rcl refused the command line (a parameter file unparsed)
        return _refuse(name, error)
    node = None
    try:
        try:
            node = make_node()
            fix_use_sim_time(node)
            if start is not None:
                start(node)
        except REFUSALS as error:
            return _refuse(name, error)
        if spin is not None:
            spin(node, stop)
        else:
            spin_nodes(node, stop=stop, executor=executor() if executor is not None else None)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            if before_destroy is not None:
                before_destroy(node)
            node.destroy_node()
        rclpy.try_shutdown()
    return EXIT_OK
