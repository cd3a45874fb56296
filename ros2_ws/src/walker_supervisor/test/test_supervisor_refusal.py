"""The supervisor node refuses bad ``supervisor.*`` parameters in one line, with exit code 2.

A bad value ended in a Python traceback; a refusal must name the parameter and start nothing
(``walker_runtime.node_main``: exit code 2).
"""

import subprocess
from pathlib import Path

import pytest

EXECUTABLE = (Path(__file__).resolve().parents[3] / 'install' / 'walker_supervisor' / 'lib'
              / 'walker_supervisor' / 'supervisor_node')


@pytest.mark.parametrize('parameter', ['supervisor.watchdog_timeout:=-1.0',
                                       'supervisor.settle_time:=long'])
def test_a_bad_supervisor_parameter_is_refused_in_one_line_with_exit_code_2(ros_env, parameter):
    run = subprocess.run([str(EXECUTABLE), '--ros-args', '-p', parameter], env=ros_env,
                         capture_output=True, text=True, timeout=120)
    output = run.stdout + run.stderr
    assert run.returncode == 2, output
    refusals = [line for line in output.splitlines() if 'refusing to start' in line]
    assert len(refusals) == 1 and parameter.split(':=')[0] in refusals[0], output
    assert 'Traceback' not in output


def test_a_truss_survey_file_that_does_not_fit_the_truss_is_refused_naming_it(ros_env,
                                                                            tmp_path):
    survey = tmp_path / 'truss_survey.yaml'
    survey.write_text('format: walker-truss-survey-1\nnodes: {n9_9: {position: [0, 0, 0]}}\n')
    parameter = f'supervisor.truss_survey_file:={survey}'
    run = subprocess.run([str(EXECUTABLE), '--ros-args', '-p', parameter], env=ros_env,
                         capture_output=True, text=True, timeout=120)
    output = run.stdout + run.stderr
    assert run.returncode == 2, output
    refusals = [line for line in output.splitlines() if 'refusing to start' in line]
    assert len(refusals) == 1 and str(survey) in refusals[0] and 'n9_9' in refusals[0], output
