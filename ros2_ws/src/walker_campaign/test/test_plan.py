"""Each run's parameters come from the seed and its index alone."""

import numpy as np
import pytest

from campaign_samples import SMALL_SPEC
from walker_campaign.core.errors import SpecError
from walker_campaign.core.plan import check_every_run, plan_run, run_location
from walker_campaign.core.spec import load_spec


def test_a_run_is_planned_the_same_from_a_fresh_read_of_the_spec(small_spec, write_spec):
    again = load_spec(write_spec(SMALL_SPEC, name='again', load=False))
    for index in range(small_spec.total_runs):
        assert plan_run(small_spec, index) == plan_run(again, index)


def test_runs_take_turns_over_the_grid_points(small_spec):
    assert [run_location(small_spec, i) for i in range(6)] == [
        (0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (1, 1)]
    with pytest.raises(SpecError, match=r'run index 12 is not a run .* \(0..11\)'):
        run_location(small_spec, 12)


def test_the_grid_points_of_a_replicate_share_its_truth(small_spec):
    """Common random numbers: the points differ in their settings only."""
    plans = [plan_run(small_spec, i) for i in range(4)]
    assert all(p.draws == plans[0].draws for p in plans)
    assert all(p.imperfection_seed == plans[0].imperfection_seed for p in plans)
    assert len({repr(p.model_values) for p in plans}) == 4
    assert plan_run(small_spec, 4).draws != plans[0].draws


def test_more_runs_extend_a_campaign_without_moving_its_runs(write_spec):
    mapping = {'seed': 3, 'runs': 3, 'route': {'target': 'n4_3'},
               'dispersions': {'damping': {'parameter': 'robot.flexibility.damping_ratio',
                                           'uniform': {'low': 0.02, 'high': 0.07}}}}
    short = write_spec(mapping)
    longer = write_spec({**mapping, 'runs': 8})
    assert [plan_run(short, i) for i in range(3)] == [plan_run(longer, i) for i in range(3)]


def test_adding_a_dispersion_leaves_the_others_draws_alone(write_spec):
    damping = {'parameter': 'robot.flexibility.damping_ratio',
               'uniform': {'low': 0.02, 'high': 0.07}}
    alone = write_spec({'seed': 3, 'runs': 5, 'route': {'target': 'n4_3'},
                        'dispersions': {'damping': damping}})
    more = write_spec({'seed': 3, 'runs': 5, 'route': {'target': 'n4_3'},
                       'dispersions': {'payload': {'parameter': 'robot.mass.gripper',
                                                   'apply': 'offset',
                                                   'uniform': {'low': 0.0, 'high': 0.5}},
                                       'damping': damping}})
    for index in range(5):
        assert plan_run(alone, index).draws['damping'] == plan_run(more, index).draws['damping']


def test_draws_apply_as_values_factors_and_offsets(small_spec):
    nominal = small_spec.nominal
    for index in range(small_spec.total_runs):
        plan = plan_run(small_spec, index)
        factor = plan.draws['friction']
        assert 0.9 <= factor <= 1.2
        for kind in ('yaw', 'pitch', 'vertex'):
            for field in ('friction_torque', 'stiction_torque'):
                name = f'robot.drive.{kind}.{field}'
                assert plan.truth_values[name] == nominal[name] * factor
        offsets = [plan.draws[f'offset:sim.imperfections.joint_offset[{i}]'] for i in range(5)]
        assert plan.truth_values['sim.imperfections.joint_offset'] == offsets
        assert len(set(offsets)) == 5  # one draw per joint
        assert plan.truth_values['sim.imperfections.seed'] == plan.imperfection_seed
        assert set(plan.model_values) == {'control.coarse.acceleration_feedback',
                                          'planner.bang_bang.torque_fraction'}
        for name, value in plan.model_values.items():
            assert plan.truth_values[name] == value  # the plant's file has the sweep too


def test_draws_follow_their_distributions(write_spec):
    spec = write_spec({'seed': 5, 'runs': 400, 'route': {'target': 'n4_3'}, 'dispersions': {
        'modes': {'parameter': 'robot.flexibility.joint1_mode', 'apply': 'scale',
                  'normal': {'mean': 1.0, 'std': 0.05, 'low': 0.95, 'high': 1.1}},
        'tolerance': {'parameter': 'gripper.insertion_position_tolerance',
                      'values': [0.0015, 0.002, 0.0025]}}})
    plans = [plan_run(spec, i) for i in range(spec.total_runs)]
    modes = np.array([p.draws['modes'] for p in plans])
    assert modes.min() >= 0.95 and modes.max() <= 1.1
    assert abs(np.median(modes) - 1.0) < 0.02
    tolerances = [p.draws['tolerance'] for p in plans]
    assert {tolerances.count(v) > 100 for v in (0.0015, 0.002, 0.0025)} == {True}
    assert len({p.imperfection_seed for p in plans}) == 400


def test_a_run_whose_drawn_truth_the_plant_refuses_is_found_before_any_walk(write_spec):
    """Each end of each distribution passes alone; together they break friction <= stiction."""
    spec = write_spec({'seed': 1, 'runs': 30, 'route': {'target': 'n4_3'}, 'dispersions': {
        'friction': {'parameter': 'robot.drive.yaw.friction_torque', 'apply': 'scale',
                     'uniform': {'low': 1.0, 'high': 1.15}},
        'stiction': {'parameter': 'robot.drive.yaw.stiction_torque', 'apply': 'scale',
                     'uniform': {'low': 0.9, 'high': 1.0}}}})
    with pytest.raises(SpecError, match=r'^run \d+ \(replicate \d+\): the plant refuses the '
                                        r'drawn truth \(friction = .*stiction = .*\): '):
        check_every_run(spec)
