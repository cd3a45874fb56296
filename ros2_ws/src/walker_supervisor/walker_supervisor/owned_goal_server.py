"""The supervisor's action servers, which end the goals a dead supervisor left behind.

:class:`OwnedGoalServer` is rclpy's ``ActionServer`` with one difference: asked for the result
of a goal that an earlier supervisor process accepted and never finished (an orphaned goal,
:class:`~walker_supervisor.core.owned_goals.OwnedGoals`), it answers at once with the goal
ABORTED and the reason (``success`` False, ``message``
:func:`~walker_supervisor.core.owned_goals.orphan_message`), where rclpy would answer UNKNOWN.
A client that asks again for the result of its goal (``walkerctl`` does every two seconds,
:mod:`walker_teleop.goal_monitor`) so learns that the goal has ended, and why.

:class:`GoalLedgerFile` keeps the ledger in ``<ROS_HOME>/walker/<namespace>_goals.yaml``
beside the step-state file (:mod:`walker_supervisor.step_state`), written atomically on every
change.
"""

from __future__ import annotations

import os
from pathlib import Path

import yaml
from action_msgs.msg import GoalStatus
from rclpy.action import ActionServer

from walker_supervisor.core.owned_goals import OwnedGoals, orphan_message

__all__ = ['OwnedGoalServer', 'GoalLedgerFile', 'goal_ledger_path']


def goal_ledger_path(namespace: str) -> Path:
    """File of the goals a robot namespace's supervisor runs (beside its step-state file)."""
    home = Path(os.environ.get('ROS_HOME', Path.home() / '.ros'))
    name = namespace.strip('/').replace('/', '_') or 'root'
    return home / 'walker' / f'{name}_goals.yaml'


class GoalLedgerFile:
    """The ledger of goals, read at start and written on every change.

    Parameters
    ----------
    path : pathlib.Path
        The file (:func:`goal_ledger_path`). A missing or unreadable file is an empty ledger.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            previous = yaml.safe_load(path.read_text())
        except (OSError, yaml.YAMLError):
            previous = None
        self.goals = OwnedGoals(previous if isinstance(previous, dict) else None)
        self._write()

    def started(self, goal_handle, action: str) -> None:
        """Note a goal this process runs."""
        self.goals.started(bytes(goal_handle.goal_id.uuid), action,
                           goal_handle.request.target_node)
        self._write()

    def ended(self, goal_handle) -> None:
        """Note that a goal's result was given."""
        self.goals.ended(bytes(goal_handle.goal_id.uuid))
        self._write()

    def _write(self) -> None:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            temporary = self.path.with_suffix('.tmp')
            temporary.write_text(yaml.safe_dump(self.goals.to_record()))
            os.replace(temporary, self.path)
        except OSError:
            pass  # the ledger helps a successor; the goal itself goes on without it


class OwnedGoalServer(ActionServer):
    """An action server that answers ABORTED for goals a dead predecessor accepted.

    Takes rclpy's ``ActionServer`` arguments plus ``ledger`` (a :class:`GoalLedgerFile`).
    """

    def __init__(self, *args, ledger: GoalLedgerFile, **kwargs) -> None:
        self._ledger = ledger
        super().__init__(*args, **kwargs)

    async def _execute_get_result_request(self, request_header_and_message):
        request_header, result_request = request_header_and_message
        goal_id = bytes(result_request.goal_id.uuid)
        orphan = None if goal_id in self._goal_handles else self._ledger.goals.orphan(goal_id)
        if orphan is None:
            return await super()._execute_get_result_request(request_header_and_message)
        response = self._action_type.Impl.GetResultService.Response()
        response.status = GoalStatus.STATUS_ABORTED
        response.result.success = False
        response.result.message = orphan_message(orphan)
        self._handle.send_result_response(request_header, response)
