"""The ledger of goals a supervisor runs, and the orphans a dead predecessor left."""

import pytest

from walker_supervisor.core.owned_goals import ORPHANS_KEPT, OwnedGoals, orphan_message

WALK = bytes(range(16))
STEP = bytes(range(16, 32))


def test_a_goal_runs_until_its_result_is_given():
    goals = OwnedGoals()
    goals.started(WALK, 'walk_to', 'n4_3')
    assert goals.running == (WALK.hex(),)
    goals.ended(WALK)
    assert goals.running == () and goals.orphaned == ()


def test_the_goals_a_dead_process_ran_are_orphans_of_the_next():
    before = OwnedGoals()
    before.started(WALK, 'walk_to', 'n4_3')
    before.started(STEP, 'step', 'n1_2')
    before.ended(STEP)  # answered: not owed by anyone
    after = OwnedGoals(before.to_record())
    assert after.running == ()
    orphan = after.orphan(WALK)
    assert orphan is not None and orphan.target_node == 'n4_3'
    assert after.orphan(STEP) is None
    assert after.orphan(WALK.hex().upper()) == orphan  # the same id, spelt as text
    again = OwnedGoals(after.to_record())  # a second restart keeps the orphans
    assert again.orphan(WALK) == orphan


def test_the_reason_names_the_goal_and_what_to_do():
    goals = OwnedGoals({'running': [{'goal_id': WALK.hex(), 'action': 'walk_to',
                                     'target_node': 'n4_3'}]})
    message = orphan_message(goals.orphan(WALK))
    assert 'walk to n4_3' in message and 'died and was started again' in message
    assert 'walkerctl status' in message


def test_orphans_are_bounded_and_damaged_entries_dropped():
    record = {'orphaned': [{'goal_id': i.to_bytes(16, 'big').hex(), 'action': 'step',
                            'target_node': 'n1_2'} for i in range(ORPHANS_KEPT + 10)]}
    record['running'] = [{'goal_id': 'not hex', 'action': 'step', 'target_node': 'n1_2'},
                         {'action': 'step'}, 'nonsense']
    goals = OwnedGoals(record)
    assert len(goals.orphaned) == ORPHANS_KEPT
    assert goals.orphan((ORPHANS_KEPT + 9).to_bytes(16, 'big')) is not None  # the newest kept
    assert goals.orphan((0).to_bytes(16, 'big')) is None  # the oldest forgotten


@pytest.mark.parametrize('bad', [b'short', 'xyz', 'g' * 32])
def test_a_malformed_goal_id_is_refused_by_name(bad):
    with pytest.raises(ValueError, match='not a goal id'):
        OwnedGoals().started(bad, 'step', 'n1_2')
