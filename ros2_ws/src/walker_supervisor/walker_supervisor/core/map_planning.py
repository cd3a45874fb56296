"""Steps planned on the truss map: stances surveyed, targets from the estimates, searches sized.

:class:`MapPlanning` is what the walk runner asks for a step's targets and its search, and
tells when a gripper has screwed in. It keeps the :class:`~walker_supervisor.core.truss_map.
TrussMap` up to date from the joints:

* the first stance (both grippers attached, no step before it) anchors the truss frame at the
  base node and surveys the other gripper's node, with the base frame's heading taken from the
  nominal direction between the two (with two nodes nothing else fixes it);
* a screw-in surveys the new node from the step's base frame (the base gripper has not moved);
* the next stance, relaxed, surveys that node again from the same frame (the old base is still
  screwed in and its frame unchanged), now with the chain's bend of the screw-in let out;
* every step's base frame is measured from its stance through the two nodes' estimates, its
  extraction starts where the joints put the moving gripper, and its coarse and fine targets
  are the map's estimate of the target node (predicted from the base node when it has not
  been surveyed: :meth:`TrussMap.predicted`);
* a jam with the gripper resting on the target node's face measures the node's height
  (:meth:`MapPlanning.felt_face`);
* a search covers ``search_sigmas`` standard deviations of the target's estimate, with no
  probe farther than ``search_radius`` from it.
"""

from __future__ import annotations

import numpy as np

from walker_core.joint_roles import physical_to_roles, roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_core.truss import Truss
from walker_supervisor.core.hole_search import HoleSearch, SearchPattern
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.step_geometry import BaseFrame, StepTargets, plan_step_targets
from walker_supervisor.core.truss_map import TrussMap

__all__ = ['MapPlanning']


class MapPlanning:
    """The truss map and the step targets planned on it.

    Parameters
    ----------
    kinematics : WalkerKinematics
    truss : Truss
        The nominal truss.
    settings : SupervisorParameters
        ``node_prior_std``, ``joint_reading_std``, ``search_radius``, ``search_sigmas``,
        ``insertion_alignment``.
    insertion_tolerance : float
        [m] ``gripper.insertion_position_tolerance``.
    approach_height : float
        [m] ``gripper.approach_height``.
    screw_length : float
        [m] ``gripper.screw_length``: a gripper beside the hole rests this high on the face.
    """

    def __init__(self, kinematics: WalkerKinematics, truss: Truss,
                 settings: SupervisorParameters, insertion_tolerance: float,
                 approach_height: float, screw_length: float) -> None:
        self.kinematics = kinematics
        self.map = TrussMap(truss, settings.node_prior_std, settings.joint_reading_std)
        self.settings = settings
        self.insertion_tolerance = float(insertion_tolerance)
        self.approach_height = float(approach_height)
        self.screw_length = float(screw_length)
        # the last step that screwed in, with its base frame: its base is still attached at
        # the next stance, which surveys the step's node again from it
        self._last: tuple[PlannedStep, BaseFrame] | None = None

    def set_settings(self, settings: SupervisorParameters) -> None:
        """Take a new ``supervisor.`` section: the map's prior and reading noise with it."""
        self.settings = settings
        self.map.prior_std = settings.node_prior_std
        self.map.joint_std = np.full(5, settings.joint_reading_std)

    def forget_stance(self) -> None:
        """Forget the last step's frame: an operator changed the stance."""
        self._last = None

    def targets(self, step: PlannedStep, theta_roles: np.ndarray) -> StepTargets:
        """Survey the stance ``theta_roles`` [rad] (role order of the step's base), then plan.

        Raises
        ------
        KinematicsError
            The heading is undefined or a target out of reach.
        """
        theta = np.asarray(theta_roles, dtype=float)
        survey = self.map
        survey.anchor_at(step.base_node)
        self._survey_again(step, theta)
        frame = BaseFrame.from_stance(self.kinematics, theta, survey.position(step.base_node),
                                      survey.position(step.from_node))
        if not survey.surveyed(step.from_node):  # the first stance
            survey.survey(step.from_node, frame, step.base_node, self.kinematics, theta)
        return plan_step_targets(self.kinematics, frame, step, survey.position(step.from_node),
                                 survey.position(step.to_node), theta, self.approach_height)

    def search(self, step: PlannedStep) -> HoleSearch | None:
        """Return the search for the step's target hole on a jam (None: ``search_radius`` 0).

        It covers ``search_sigmas`` standard deviations of the target's estimate along its
        worst horizontal direction, no probe farther than ``search_radius`` from the estimate
        (:meth:`SearchPattern.around`); probes the arm cannot reach are passed over.
        """
        settings = self.settings
        if settings.search_radius <= 0.0:
            return None
        reach = self.insertion_tolerance - settings.insertion_alignment
        estimate = self.map.estimate(step.to_node)
        return HoleSearch(SearchPattern.around(reach, estimate.horizontal_std,
                                               settings.search_sigmas, settings.search_radius))

    def felt_face(self, step: PlannedStep, frame: BaseFrame, theta_roles: np.ndarray) -> None:
        """Take the target node's height from a jam, the gripper resting on the node's face.

        A screw-in jams when the screw's tip is beside the hole (over the chamfer the node
        guides it into the bore), so the gripper rests ``screw_length`` above the mouth: the
        joints ``theta_roles`` [rad] (role order of the step's base, whose frame is ``frame``)
        measure the node's height (:meth:`TrussMap.measure_height`, ``face_height_std``).
        """
        self.map.measure_height(step.to_node, frame, step.base_node, self.kinematics,
                                theta_roles, self.screw_length, self.settings.face_height_std)

    def screwed_in(self, step: PlannedStep, targets: StepTargets,
                   theta_roles: np.ndarray) -> None:
        """Survey the node the step's gripper has screwed into; ``theta_roles`` [rad] of its base.

        ``targets`` are the step's (their frame is the base's).
        """
        self.map.survey(step.to_node, targets.frame, step.base_node, self.kinematics,
                        theta_roles)
        self._last = (step, targets.frame)

    def _survey_again(self, step: PlannedStep, theta_roles: np.ndarray) -> None:
        """Survey the stance's base node from the last step's frame, if that step made it."""
        if self._last is None:
            return
        last, frame = self._last
        if last.to_node != step.base_node or last.base_node != step.from_node:
            return
        # the same joints, in the role order of the last step's base (the moving gripper now)
        old_roles = physical_to_roles(roles_to_physical(theta_roles, step.base_gripper),
                                      last.base_gripper)
        self.map.survey(step.base_node, frame, last.base_node, self.kinematics, old_roles)
