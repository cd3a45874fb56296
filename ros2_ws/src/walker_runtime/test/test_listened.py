"""ListenedPublisher: nothing sent while nobody subscribes, sent again once someone does."""

from walker_runtime.listened import ListenedPublisher


class _Publisher:
    def __init__(self):
        self.subscribers = 0
        self.sent = []
        self.asked = 0

    def get_subscription_count(self):
        self.asked += 1
        return self.subscribers

    def publish(self, message):
        self.sent.append(message)


def test_messages_flow_only_while_a_subscriber_matches_and_the_count_is_asked_rarely():
    clock = {'now': 10.0}
    publisher = _Publisher()
    listened = ListenedPublisher(publisher, steady_now=lambda: clock['now'],
                                 recheck_period=0.1)
    for k in range(50):  # 50 periods of 2 ms: nobody listens
        listened.publish(k)
        clock['now'] += 0.002
    assert publisher.sent == [] and publisher.asked == 1
    publisher.subscribers = 1  # `ros2 topic echo` starts
    clock['now'] += 0.15
    listened.publish('heard')
    assert publisher.sent == ['heard'] and listened.heard
    publisher.subscribers = 0
    clock['now'] += 0.15
    assert not listened.heard
