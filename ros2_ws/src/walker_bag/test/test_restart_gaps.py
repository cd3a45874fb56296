"""What a recorder started again did not record: span and estimated count per topic."""

from walker_bag.core.bag_metadata import FileInformation
from walker_bag.core.losses import loss_lines, recorded_losses
from walker_bag.core.restart_gaps import GAP_KEY, RestartGaps

S = 1_000_000_000


def _file(start_s, span_s, counts):
    return (FileInformation('bag_0.mcap', start_s * S, span_s * S, sum(counts.values())),
            counts)


def test_each_topic_gap_spans_from_the_bags_end_to_its_first_message_at_its_rate():
    gaps = RestartGaps.after([_file(10, 4, {'/walker/joint_states': 2000,
                                            '/walker/phase': 4})])
    assert gaps.end_ns == 14 * S
    js = gaps.first_message('/walker/joint_states', int(15.67 * S))
    assert js.topic == '/walker/joint_states' and js.span == 1.67
    assert js.estimated == 835  # 500 Hz for 1.67 s
    assert gaps.first_message('/walker/joint_states', 16 * S) is None  # once per topic
    assert gaps.first_message('/walker/new_topic', 16 * S) is None  # no rate before: no gap
    assert gaps.custom_data() == {GAP_KEY: f'{14 * S} {int(15.67 * S)} 835',
                                  f'{GAP_KEY} /walker/joint_states':
                                      f'{14 * S} {int(15.67 * S)} 835'}
    assert 'not recorded for 1.67 s' in js.text() and 'about 835 messages' in js.text()


def test_no_earlier_file_means_no_gap_and_a_second_restart_adds_to_the_first():
    assert RestartGaps.after([]) is None
    first = RestartGaps.after([_file(0, 2, {'/walker/phase': 20})])
    first.first_message('/walker/phase', 3 * S)
    second = RestartGaps.after([_file(0, 5, {'/walker/phase': 50})], first.custom_data())
    second.first_message('/walker/phase', 6 * S)
    losses = recorded_losses({**second.custom_data(), 'messages_lost': '0'})
    assert [(g['topic'], g['span'], g['estimated']) for g in losses['not_recorded']] == [
        ('/walker/phase', 1.0, 10), ('/walker/phase', 1.0, 10)]


def test_the_summary_of_a_bag_names_its_losses_and_its_gaps():
    losses = recorded_losses({'messages_lost': '477', 'messages_lost /walker/joint_states': '405',
                              'messages_lost /clock': '72', f'{GAP_KEY} /walker/joint_states':
                                  f'{10 * S} {int(11.67 * S)} 834', 'clock': 'sim_time'})
    assert losses['messages_lost'] == 477 and losses['lost']['/clock'] == 72
    assert losses['not_recorded'][0]['estimated'] == 834
    lines = loss_lines(losses)
    assert lines[0].startswith('477 messages lost on the way to the recorder: /clock 72')
    assert 'about 834 messages not recorded while the recorder was down (up to 1.67 s)' \
        in lines[1]
    assert loss_lines(recorded_losses({'messages_lost': '0'})) == []
