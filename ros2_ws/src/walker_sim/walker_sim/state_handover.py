"""Sim time: the plant's states handed by call to controllers in the same process.

As Gazebo's ros2_control plugin runs its controllers inside the simulator, a plant and the
five controllers composed in one process (``run_all.py --composed-loop``) exchange the
lock-step's state and efforts by two calls instead of two messages through DDS and two
processes woken (:meth:`walker_sim.plant_node.PlantNode.hand_states_to`). With the whole graph
in the process, the planner's stream takes each state by call first, and its setpoints for the
coming states go to the controllers by call (:mod:`walker_control.setpoint_handover`): the
lock-step then waits on no message at all.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ['StateHandover']


class StateHandover:
    """The newest state for the controllers in this process, handed over outside callbacks.

    Parameters
    ----------
    controllers
        A controller node answering every joint (``walker_control.joint_controllers_node``):
        ``take_accelerations(message)`` and ``take_state(message)``.
    steady_now : callable
        The steady clock [s].
    planner : optional
        A planner node streaming by call (``walker_planner.planner_node``): ``take_state``
        (message), before the controllers.
    """

    def __init__(self, controllers, steady_now: Callable[[], float], planner=None) -> None:
        self._controllers = controllers
        self._planner = planner
        self._steady_now = steady_now
        self._waiting: tuple | None = None
        self._running = False

    def offer(self, accelerations, joint_states) -> None:
        """Keep the state just published for the next :meth:`run`.

        Never handed over from inside the controllers' own callbacks: their answer is still
        being sent.
        """
        self._waiting = (accelerations, joint_states)

    @property
    def pending(self) -> bool:
        """A state waits to be handed over."""
        return self._waiting is not None

    def run(self, budget: float) -> None:
        """Hand the waiting state over, and the next, and so on, for at most ``budget`` [s].

        The controllers' answer steps the plant, which offers the next state: the loop runs
        here, not by recursion, until an answer does not come at once (a controller waiting
        for its setpoint answers later, from its own callback) or the budget is spent.
        """
        if self._running:
            return
        self._running = True
        try:
            end = self._steady_now() + budget
            while self._waiting is not None:
                accelerations, state = self._waiting
                self._waiting = None
                if self._planner is not None:
                    self._planner.take_state(state)
                self._controllers.take_accelerations(accelerations)
                self._controllers.take_state(state)
                if self._steady_now() > end:
                    break
        finally:
            self._running = False
