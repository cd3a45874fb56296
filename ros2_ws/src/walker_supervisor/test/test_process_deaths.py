"""A hold the bring-up asks for after a node died names the dead node, not an operator."""

from walker_supervisor.core.process_deaths import OPERATOR_HOLD, ProcessDeaths


def test_a_hold_after_a_reported_death_names_the_dead_node():
    deaths = ProcessDeaths('/walker')
    deaths.status('/walker/controller_vertex (process)', 2,
                  'died (killed by SIGKILL) and is not started again: it died 4 times', 100.0)
    reason = deaths.hold_reason(101.5)
    assert reason.startswith('hold requested by the bring-up: node /walker/controller_vertex')
    assert 'killed by SIGKILL' in reason


def test_an_operator_hold_stays_an_operator_hold():
    deaths = ProcessDeaths('/walker')
    assert deaths.hold_reason(5.0) == OPERATOR_HOLD
    # a restart, another robot's death, another node's status, or an old death: not the cause
    deaths.status('/walker/planner (process)', 0, 'started again (restart 1)', 5.0)
    deaths.status('/walker_2/planner (process)', 2, 'died (exit code 1)', 5.0)
    deaths.status('/walker/plant: plant', 2, 'something', 5.0)
    assert deaths.hold_reason(6.0) == OPERATOR_HOLD
    deaths.status('/walker/planner (process)', 2, 'died (exit code 1)', 6.0)
    assert deaths.hold_reason(60.0) == OPERATOR_HOLD
