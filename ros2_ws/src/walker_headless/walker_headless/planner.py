"""The planner node's services on the planner core and the loop's streamer, by calls.

What the supervisor's requests get from the planner node over ROS, they get here from the same
cores:

* ``plan_trajectory``: :func:`~walker_planner.core.planning.plan` of the request the walk
  runner made (:func:`~walker_supervisor.core.planner_calls.planner_call`), answered as a
  :class:`~walker_supervisor.core.prepared_motions.PlanAnswer` whose trajectory has the form
  ``trajectory_msgs/JointTrajectory`` gives it on the way (its times rounded to the
  nanosecond), and published on ``planned_trajectory`` as the node publishes every plan;
* joining two answers streamed as one (the supervisor's ``join``, as
  :func:`walker_planner.conversions.chained_message`);
* ``follow_trajectory``: refused while a stream runs; checked against the joint limits as a
  goal is (aborted when it is not within them); streamed by the loop's
  :class:`~walker_planner.core.streamer.TrajectoryStreamer`, whose streams carry the ticket of
  the request; its end (:meth:`HeadlessPlanner.take_ended`), complete or cancelled;
* ``stop_trajectory``.

Planning takes no simulated time: in the graph the supervisor holds the simulated clock while
it waits for the planner (``supervisor/decided_until``).
"""

from __future__ import annotations

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.core.chaining import chain
from walker_planner.core.errors import PlanningError
from walker_planner.core.planning import PlanningContext, PlanRequest, plan
from walker_planner.core.streaming import SampledTrajectory
from walker_supervisor.core.prepared_motions import PlanAnswer, stream_lead

from walker_headless.loop import RobotLoop

__all__ = ['HeadlessPlanner', 'as_sent', 'message_time']

_NS_PER_S = 1_000_000_000


def message_time(seconds: float) -> float:
    """Return a time [s] as ``builtin_interfaces/Duration`` carries it: to the nanosecond."""
    total = int(round(seconds * _NS_PER_S))
    return total // _NS_PER_S + (total % _NS_PER_S) / _NS_PER_S


def as_sent(times, positions, velocities, accelerations, robot=None) -> SampledTrajectory:
    """Return the trajectory of these samples as a ``JointTrajectory`` message carries it.

    With ``robot`` (``WalkerParameters``), checked against the joint limits as the planner
    checks a ``follow_trajectory`` goal.

    Raises
    ------
    PlanningError
        Naming what is wrong (:meth:`SampledTrajectory.from_points`).
    """
    times = [message_time(float(t)) for t in times]
    if robot is None:  # the planner core's own samples: in order, finite, only rounded
        return SampledTrajectory(np.array(times), np.asarray(positions, dtype=float),
                                 np.asarray(velocities, dtype=float),
                                 np.asarray(accelerations, dtype=float))
    return SampledTrajectory.from_points(PHYSICAL_JOINT_NAMES, times, positions, velocities,
                                         accelerations, robot)


class HeadlessPlanner:
    """The planner node's ``plan_trajectory``, ``follow_trajectory`` and ``stop_trajectory``.

    Parameters
    ----------
    loop : RobotLoop
        Its streamer streams; its recording (if any) takes ``planned_trajectory``.
    """

    def __init__(self, loop: RobotLoop) -> None:
        self.loop = loop
        configuration = loop.configuration
        self._robot = configuration.walker
        self._context = PlanningContext.from_parameters(configuration.walker,
                                                        configuration.planner)

    def plan(self, call: PlanRequest) -> PlanAnswer:
        """Answer a ``plan_trajectory`` request."""
        try:
            result = plan(call, self._context)
        except PlanningError as error:
            return PlanAnswer(False, str(error))
        trajectory = as_sent(result.times, *result.samples)
        self._publish(trajectory)
        return PlanAnswer(True, '', result.duration, result.time_optimal_bound or 0.0,
                          trajectory)

    @staticmethod
    def join(first: PlanAnswer, second: PlanAnswer, lead: float) -> SampledTrajectory:
        """Two answers as one trajectory, the second from ``lead`` [s] before the first ends.

        Raises
        ------
        PlanningError
            They cannot stream as one.
        """
        joined = chain(first.trajectory, second.trajectory, stream_lead(first, second, lead))
        return as_sent(joined.times, joined.positions, joined.velocities,
                       joined.accelerations)

    def follow(self, ticket: int, trajectory: SampledTrajectory) -> tuple[bool, str | None]:
        """Take a ``follow_trajectory`` goal named ``ticket``.

        Returns whether it is accepted, and for one accepted but aborted at once (beyond the
        joint limits, or refused by the streamer) why (else None: it streams).
        """
        streamer = self.loop.streamer
        if streamer.active is not None:
            return False, None
        try:
            goal = as_sent(trajectory.times, trajectory.positions, trajectory.velocities,
                           trajectory.accelerations, self._robot)
            active = streamer.start(goal, ticket)
        except PlanningError as error:
            return True, str(error)
        self._publish(goal, active.stream.origin)
        return True, None

    def _publish(self, trajectory: SampledTrajectory, start: int = 0) -> None:
        """``planned_trajectory``: to the bag, and the viz node that draws it."""
        loop = self.loop
        if loop.recording is not None:
            loop.recording.planned_trajectory(loop.stamp, trajectory, start)
            loop.viz.plan(loop.stamp, trajectory.positions)

    def cancel(self, ticket: int) -> None:
        """Cancel the stream of ``ticket``, if it runs: it ends where its sent setpoints end."""
        active = self.loop.streamer.active
        if active is not None and active.owner == ticket and not active.ended:
            self.loop.streamer.end_now(active, 'cancelled')

    def stop(self) -> None:
        """``stop_trajectory``: stop whatever streams."""
        self.loop.streamer.stop()

    def take_ended(self) -> list[tuple[int, bool, str]]:
        """Return the streams that ended at this state: (ticket, completed, message) each."""
        return [(active.owner, not active.cancelled, active.message)
                for active in self.loop.streamer.take_ended()]
