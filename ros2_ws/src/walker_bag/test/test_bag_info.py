"""``bag_info``: the summary of a bag, recovery of a cut one, clear errors."""

from walker_bag.bag_info import main
from walker_bag.core.bag_metadata import read_metadata

from walker_bag_samples import WALK_TOPICS


def test_the_summary_lists_every_topic_with_its_type_count_and_durability(walk_bag, capsys):
    path, written = walk_bag
    assert main([str(path)]) == 0
    out = capsys.readouterr().out
    assert 'Storage id:        mcap' in out
    assert 'ROS Distro:        jazzy' in out
    assert f'Messages:          {len(written)}' in out
    for name, type_name, qos in WALK_TOPICS:
        assert (f'Topic: {name} | Type: {type_name} | Count: 20 | Serialization Format: cdr | '
                f'Durability: {qos.durability}') in out


def test_recover_writes_a_complete_copy(walk_bag, tmp_path, capsys):
    path, written = walk_bag
    destination = tmp_path / 'copy'
    assert main([str(path), '--recover', str(destination)]) == 0
    assert f'recovered {len(written)} messages' in capsys.readouterr().out
    assert read_metadata(destination).message_count == len(written)


def test_a_directory_that_is_not_a_bag_gives_a_clear_error(tmp_path, capsys):
    assert main([str(tmp_path)]) == 2
    assert 'metadata.yaml' in capsys.readouterr().err
