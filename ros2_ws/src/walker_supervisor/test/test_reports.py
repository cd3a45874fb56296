"""The fields of the supervisor's records are the fields of the messages both shells publish."""

import math

from walker_msgs.msg import StepPhase, StepReport

from walker_supervisor.core.commands import PhaseRecord, StepRecord
from walker_supervisor.core.phases import Phase, StepOutcome
from walker_supervisor.core.reports import phase_fields, report_fields
from walker_supervisor.core.route import PlannedStep


def _message_fields(message_type) -> set[str]:
    return {name.lstrip('_') for name in message_type.get_fields_and_field_types()} - {'header'}


def test_a_step_record_fills_every_field_of_a_step_report():
    step = PlannedStep(base_gripper='a', base_node='n1_1', from_node='n2_1', to_node='n1_2',
                       sweep=math.pi / 2)
    outcome = StepOutcome(True, '', {'extraction': 1.0, 'coarse': 2.0}, 4.0, 1e-4, 1)
    fields = report_fields(StepRecord(0, 2, step, outcome, 3.2, 2e-4, 5e-5))
    assert set(fields) == _message_fields(StepReport)
    message = StepReport(**fields)
    assert (message.to_node, message.phase_names, list(message.phase_durations)) == \
        ('n1_2', ['extraction', 'coarse'], [1.0, 2.0])
    assert message.bound_ratio == 4.0 / 3.2 and message.insertion_error_estimated == 1e-4


def test_a_phase_record_fills_every_field_of_a_step_phase():
    record = PhaseRecord(Phase.COARSE, 'a', '', 0.5, 1, 2, 'n2_1', 'n1_2', 'n1_1', 0.25)
    fields = phase_fields(record)
    assert set(fields) == _message_fields(StepPhase)
    message = StepPhase(**fields)
    assert message.phase == int(Phase.COARSE) and message.base_heading == 0.25
