"""The one walk summary: what summary.json is written from, and run_all.py's exit code."""

import json

import pytest

from walker_core.walk_summary import Runner, WalkSummary


def _summary(**changes) -> WalkSummary:
    fields = {'target': 'n1_2', 'reached': True, 'message': '', 'path': ('n1_2',),
              'steps_taken': 1, 'duration': 4.5}
    return WalkSummary(**{**fields, **changes})


def test_the_fields_written_to_summary_json_are_plain_json():
    summary = _summary(runner=Runner.HEADLESS)
    written = json.loads(json.dumps(summary.json_fields('target', 'path', 'runner')))
    assert written == {'target': 'n1_2', 'path': ['n1_2'], 'runner': 'headless'}


def test_a_field_that_is_not_there_is_named():
    with pytest.raises(AttributeError, match='no field step_count'):
        _summary().json_fields('target', 'step_count')


def test_the_exit_code_says_whether_the_target_was_reached():
    assert _summary().code == 0
    assert _summary(reached=False, message='no path').code == 1
