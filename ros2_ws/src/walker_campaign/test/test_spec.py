"""The campaign spec: what it reads, and every way it refuses a bad one, naming the field."""

import pytest
import yaml

from walker_campaign.core.errors import SpecError
from walker_campaign.core.spec import load_spec


def base(**changes):
    spec = {'seed': 1, 'runs': 4, 'route': {'target': 'n4_3'}}
    spec.update(changes)
    return spec


def test_a_spec_reads_into_its_grid_and_columns(small_spec):
    assert small_spec.point_count == 4 and small_spec.total_runs == 12
    assert small_spec.grid == [(0.0, 0.7), (0.0, 0.8), (0.25, 0.7), (0.25, 0.8)]
    friction = small_spec.dispersions[0]
    assert sorted(t.key for t in friction.targets) == sorted(
        f'robot.drive.{k}.{f}' for k in ('yaw', 'pitch', 'vertex')
        for f in ('friction_torque', 'stiction_torque'))
    assert friction.columns == ('friction',)
    assert small_spec.draw_columns[1:] == tuple(
        f'offset:sim.imperfections.joint_offset[{i}]' for i in range(5))
    assert small_spec.model_values(2)['control.coarse.acceleration_feedback'][0] == 0.25


def test_the_digest_follows_what_decides_a_run_but_not_the_number_of_runs(write_spec):
    first = write_spec(base())
    assert write_spec(base()).digest == first.digest
    assert write_spec(base(runs=9)).digest == first.digest
    assert write_spec(base(seed=2)).digest != first.digest
    assert write_spec(base(route={'target': 'n3_3'})).digest != first.digest


def test_an_integer_where_a_float_is_due_is_taken_as_a_float(write_spec):
    spec = write_spec(base(sweeps={'control.filter.corner[0]': [5, 6]}))
    assert spec.sweeps[0].values == (5.0, 6.0)
    assert all(isinstance(v, float) for v in spec.sweeps[0].values)


def test_a_spec_file_is_read_with_its_own_params_file(write_spec, tmp_path):
    from walker_core.robot_parameters import default_parameter_file

    (tmp_path / 'mine.yaml').write_text(default_parameter_file().read_text())
    spec = write_spec(base(params_file='mine.yaml'))
    assert spec.params_file == (tmp_path / 'mine.yaml').resolve()


FRICTION = {'parameters': ['robot.drive.*.friction_torque'], 'apply': 'scale',
            'uniform': {'low': 0.9, 'high': 1.1}}


@pytest.mark.parametrize('changes, named', [
    ({'seeds': 3}, r'campaign spec: unknown key seeds'),
    ({'runs': 0}, r'^runs: expected an integer'),
    ({'runs': 2.5}, r'^runs: expected an integer'),
    ({'seed': -1}, r'^seed: expected an integer'),
    ({'name': 'a b'}, r'^name:'),
    ({'route': {'target': 'n9_9'}}, r'^route.target: node .n9_9. is not on the truss'),
    ({'route': {'target': 'n1_1', 'speed': 2}}, r'^route: unknown key speed'),
    ({'route': {'target': 'n4_3', 'walk_timeout': -5}}, r'^route.walk_timeout'),
    ({'params_file': 'missing.yaml'}, r'^params_file: cannot read parameter file'),
    ({'dispersions': {'x': {'parameter': 'control.fine.bandwidth[0]', 'uniform':
                            {'low': 0.5, 'high': 0.8}}}},
     r'^dispersions.x.parameters\[0\]: control.fine.bandwidth cannot be dispersed \(a sweep'),
    ({'dispersions': {'x': {'parameter': 'sim.physics_rate', 'values': [2000.0]}}},
     r'sim.physics_rate cannot be dispersed \(it is not a property of the robot'),
    ({'dispersions': {'x': {'parameter': 'sim.imperfections.seed', 'values': [3.0]}}},
     r'cannot be dispersed \(the campaign sets it'),
    ({'dispersions': {'x': {'parameter': 'robot.flexibility.segments_per_link',
                            'values': [3.0]}}}, r'is not a real number'),
    ({'dispersions': {'x': {'parameter': 'robot.drive.*.nothing', 'values': [1.0]}}},
     r'names no parameter'),
    ({'dispersions': {'x': {'parameter': 'sim.imperfections.joint_offset[7]',
                            'values': [0.0]}}}, r'has 5 elements \(0..4\), not \[7\]'),
    ({'dispersions': {'x': {'parameter': 'robot.mass.link[0]', 'values': [1.0]}}},
     r'robot.mass.link is a single value'),
    ({'dispersions': {'x': {**FRICTION, 'apply': 'times'}}}, r'^dispersions.x.apply'),
    ({'dispersions': {'x': {**FRICTION, 'normal': {'mean': 1, 'std': 1}}}},
     r'^dispersions.x: give exactly one distribution'),
    ({'dispersions': {'x': {'parameters': FRICTION['parameters'],
                            'normal': {'mean': 1.0, 'std': 0.0}}}},
     r'^dispersions.x.normal.std: must be positive'),
    ({'dispersions': {'x': {'parameters': FRICTION['parameters'],
                            'normal': {'mean': 1.0, 'std': 0.1, 'low': 2.0, 'high': 3.0}}}},
     r'holds only'),
    ({'dispersions': {'x': {'parameters': FRICTION['parameters'],
                            'uniform': {'low': 2.0, 'high': 1.0}}}},
     r'^dispersions.x.uniform: low \(2\) must be below high'),
    ({'dispersions': {'x': {'parameters': FRICTION['parameters'], 'gauss': {}}}},
     r'^dispersions.x: unknown key gauss'),
    ({'dispersions': {'x': {**FRICTION, 'per_parameter': 'yes'}}},
     r'^dispersions.x.per_parameter'),
    ({'dispersions': {'x': FRICTION, 'y': FRICTION}},
     r'^dispersions.y: robot.drive.\w+.friction_torque is already dispersed by dispersions.x'),
    ({'dispersions': {'x': {**FRICTION, 'uniform': {'low': 0.5, 'high': 1.0}}}},
     r'^dispersions.x: at 0.5 \(scale\) the plant refuses the truth: .*friction_torque.*10%'),
    ({'sweeps': {'robot.mass.link': [0.4, 0.6]}},
     r'^sweeps.robot.mass.link: robot.mass.link is not a setting of the controllers'),
    ({'sweeps': {'control.*.bandwidth[0]': [0.5]}}, r'not a pattern'),
    ({'sweeps': {'control.filter.corner[0]': [5.0, -1.0]}},
     r'^sweeps.control.filter.corner\[0\]\[1\] = -1.0: the walker refuses it: .*corner'),
    ({'sweeps': {'control.filter.corner[0]': [5.0, 5.0]}}, r'a value is listed twice'),
    ({'sweeps': {'control.filter.corner[0]': []}}, r'expected a non-empty list'),
    ({'sweeps': {'control.nothing': [1.0]}}, r"'control.nothing' is not a parameter"),
    ({'sweeps': {'control.state_timeout': [0.5, 0.4],
                 'control.sim_time_setpoint_wait': [0.3, 0.45]}},
     r'^sweeps: the grid point control.state_timeout = 0.4, '
     r'control.sim_time_setpoint_wait = 0.45 is refused by the walker: .*state_timeout'),
])
def test_a_bad_spec_is_refused_naming_the_field(write_spec, changes, named):
    with pytest.raises(SpecError, match=named):
        write_spec(base(**changes))


def test_a_missing_or_broken_spec_file_is_refused(tmp_path):
    with pytest.raises(SpecError, match='cannot read campaign spec'):
        load_spec(tmp_path / 'nothing.yaml')
    (tmp_path / 'broken.yaml').write_text('seed: [1,\n')
    with pytest.raises(SpecError, match='is not valid YAML'):
        load_spec(tmp_path / 'broken.yaml')
    (tmp_path / 'list.yaml').write_text('- 1\n')
    with pytest.raises(SpecError, match='campaign spec: expected a mapping'):
        load_spec(tmp_path / 'list.yaml')


SHIPPED = ['default_walk', 'ka_filter_sweep', 'truss_as_built', 'truss_twice',
           'truss_as_built_camera', 'default_walk_camera', 'truss_as_built_4mm_camera']


@pytest.mark.parametrize('name', SHIPPED)
def test_the_shipped_specs_are_valid(name):
    from walker_campaign.core.spec import shipped_spec

    spec = load_spec(shipped_spec(name))
    assert spec.name == name


def test_the_shipped_specs_are_all_tested():
    from walker_campaign.core.spec import shipped_spec

    folder = shipped_spec('default_walk').parent
    assert sorted(p.stem for p in folder.glob('*.yaml')) == sorted(SHIPPED)


def test_a_camera_spec_is_its_base_with_the_cameras_on_run_for_run():
    """default_walk_camera meets default_walk's truths run for run, the cameras on."""
    from walker_campaign.core.plan import plan_run
    from walker_campaign.core.spec import shipped_spec

    blind, camera = (load_spec(shipped_spec(n)) for n in ('default_walk', 'default_walk_camera'))
    assert camera.seed == blind.seed and camera.runs == blind.runs
    assert [d.name for d in camera.dispersions] == [d.name for d in blind.dispersions]
    for index in (0, 7):
        truth = dict(plan_run(camera, index).truth_values)
        assert truth.pop('gripper.camera.enabled') is True  # the plant renders the frames
        assert truth == plan_run(blind, index).truth_values
        assert plan_run(camera, index).model_values['gripper.camera.enabled'] is True
    wide = load_spec(shipped_spec('truss_as_built_4mm_camera'))
    placement = {d.name: d for d in wide.dispersions}['node_placement']
    assert repr(placement.distribution) != repr(
        {d.name: d for d in camera.dispersions}['node_placement'].distribution)


def test_a_spec_that_extends_another_changes_only_what_it_says(write_spec, tmp_path):
    from walker_core.robot_parameters import default_parameter_file

    (tmp_path / 'mine.yaml').write_text(default_parameter_file().read_text())
    sensor = {'parameter': 'sim.imperfections.joint_noise', 'values': [0.00002]}
    write_spec(base(params_file='mine.yaml', dispersions={'friction': FRICTION, 'noise': sensor},
                    sweeps={'control.filter.corner[0]': [5.0, 6.0]}), name='first', load=False)
    (tmp_path / 'sub').mkdir()
    (tmp_path / 'sub' / 'second.yaml').write_text(yaml.safe_dump({
        'extends': '../first.yaml', 'runs': 9, 'route': {'walk_timeout': 60},
        'dispersions': {'friction': None, 'noise': dict(sensor, values=[0.00004])},
        'sweeps': {'gripper.camera.enabled': [True]}}))
    first, second = load_spec(tmp_path / 'first.yaml'), load_spec(tmp_path / 'sub/second.yaml')
    assert second.name == 'second' and second.runs == 9 and second.seed == first.seed
    assert second.target == first.target and second.walk_timeout == 60
    assert second.params_file == (tmp_path / 'mine.yaml').resolve()  # beside the base
    assert [d.name for d in second.dispersions] == ['noise']
    assert [s.target.key for s in second.sweeps] == ['control.filter.corner[0]',
                                                     'gripper.camera.enabled']


@pytest.mark.parametrize('extends, words', [
    ('nothing.yaml', 'no campaign spec file'),
    ('loop.yaml', 'a cycle of campaign specs'),
    (3, 'extends: expected a spec file'),
])
def test_a_bad_extends_is_refused_naming_it(tmp_path, extends, words):
    (tmp_path / 'loop.yaml').write_text(yaml.safe_dump(base(extends='loop.yaml')))
    (tmp_path / 'child.yaml').write_text(yaml.safe_dump(base(extends=extends)))
    with pytest.raises(SpecError, match=words):
        load_spec(tmp_path / 'child.yaml')


@pytest.mark.parametrize('changes, words', [
    # a rule between the supervisor's and the gripper's sections
    ({'supervisor.insertion_alignment': 0.004, 'supervisor.coarse_to_fine_region': 0.01,
      'supervisor.descent_region': 0.005, 'supervisor.descent_axis_tolerance': 0.006,
      'supervisor.search_radius': 0.006},
     'smaller than gripper.insertion_position_tolerance'),
    # and one of the plant's, on the model's set
    ({'sim.physics_rate': 1250.0}, 'integer multiple of timing.control_rate'),
])
def test_a_model_set_is_checked_by_every_rule_the_graph_checks(changes, words):
    from walker_campaign.core.parameter_sets import check_model
    from walker_core.parameter_file import default_values
    from walker_core.parameter_schema import ParameterError

    with pytest.raises(ParameterError, match=words):
        check_model({**default_values(), **changes})
