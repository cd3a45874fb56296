"""The step under way, kept in a file so that a restarted supervisor can complete it.

The supervisor writes the step (its nodes, its base gripper, the heading of the base frame and
the truss map it was planned on) when the step starts and removes the file when it completes
(:class:`~walker_supervisor.core.commands.RecordStep`,
:class:`~walker_supervisor.core.commands.ForgetRecordedStep`). A supervisor that starts reads
it back, and takes the step up if the grippers are as the file says
(:mod:`walker_supervisor.core.adoption`). The file lives under ``$ROS_HOME`` (default
``~/.ros``) like ROS 2's own logs, one per robot namespace.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import yaml

from walker_supervisor.core.adoption import RecordedStep
from walker_supervisor.core.route import PlannedStep

__all__ = ['step_state_path', 'write_step_state', 'read_step_state', 'clear_step_state']


def step_state_path(namespace: str) -> Path:
    """File of the step under way for a robot namespace."""
    home = Path(os.environ.get('ROS_HOME', Path.home() / '.ros'))
    name = namespace.strip('/').replace('/', '_') or 'root'
    return home / 'walker' / f'{name}_step.yaml'


def write_step_state(path: Path, step: PlannedStep, heading: float,
                     survey: dict | None = None) -> None:
    """Record the step under way (atomically: a crash leaves the old file or the new one).

    ``survey`` is the truss map the step was planned on (a survey file's content), if any.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {'base_gripper': step.base_gripper, 'base_node': step.base_node,
            'from_node': step.from_node, 'to_node': step.to_node, 'heading': float(heading)}
    if survey is not None:
        data['survey'] = survey
    temporary = path.with_suffix('.tmp')
    temporary.write_text(yaml.safe_dump(data))
    os.replace(temporary, path)


def read_step_state(path: Path) -> RecordedStep | None:
    """Read the recorded step; None when there is none or the file is not one of ours."""
    try:
        data = yaml.safe_load(path.read_text())
        step = RecordedStep(str(data['base_gripper']), str(data['base_node']),
                            str(data['from_node']), str(data['to_node']),
                            float(data['heading']))
        survey = data.get('survey')
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return None
    return dataclasses.replace(step, survey=survey) if isinstance(survey, dict) else step


def clear_step_state(path: Path) -> None:
    """Forget the step (it completed)."""
    try:
        path.unlink()
    except FileNotFoundError:
        pass
