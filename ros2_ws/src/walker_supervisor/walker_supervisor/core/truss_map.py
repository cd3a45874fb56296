"""The truss as built: each node's place as the walker's own joints have measured it.

The parameter file gives every node a nominal place; a truss as built has its nodes off those
places by millimetres, more than the gripper's insertion tolerance. The walker has no tip
sensing (paper section 2), but whenever both grippers are screwed in, the forward kinematics of
eq (1) of the measured joints from the base gripper's node says where the other gripper's node
is. :class:`TrussMap` keeps, for each node, its estimated position in the *truss frame* with a
covariance:

* a node never surveyed is predicted from the surveyed node that knows it best, along the
  nominal vector between them, with that node's covariance plus ``node_prior_std`` squared per
  bay of distance squared (:meth:`TrussMap.predicted`: a neighbour is known relative to a
  surveyed node to the truss's placement, and the first stance's heading error turns far
  nodes off their drawn places); in a map with nothing surveyed it is at its nominal place
  with ``node_prior_std`` along x, y and z;
* the node the walk starts from (the base of the first stance) anchors the frame: it is taken
  at its nominal place with no uncertainty, so every other estimate is relative to it;
* a survey measures a node at the base frame's image of the forward kinematics
  (:meth:`TrussMap.measure`), with the base node's covariance plus the joint readings' noise
  propagated through the Jacobian of eq (1): ``C = C_base + R J S J^T R^T``, ``S`` the
  joint readings' variances (``joint_reading_std``, offset and noise together), ``R`` the base
  frame's heading. The base node's covariance makes the measurement's uncertainty grow along
  the chain of stances it was taken through;
* a surveyed node's estimate is that measurement fused with what the map knew of the node
  before (:meth:`TrussMap.survey`, :func:`fuse`: the least-squares update of two estimates
  weighted by their covariances): the nominal place with the prior, or an earlier walk's
  estimate (not the prediction, which is taken through the same base node as the survey). A
  survey taken through a long chain (a large covariance) barely moves a node known well, and
  the nominal place bounds the drift that the joints' constant calibration offsets
  would otherwise add step after step. A node surveyed again from the same base (the relaxed
  stance after a screw-in) takes the new reading in place of the old one, fused with the same
  prior: the two readings share their offsets and are not two measurements.

The base frame's heading is taken again from each stance (both grippers attached) through the
two nodes' estimates, so it follows the map; its own error is that of the two estimates and is
not carried as a separate term. A node's height is carried like x and y: the descent goes to the
estimated mouth. A height felt with the gripper resting on the node's face
(:meth:`TrussMap.measure_height`) updates the estimate's height alone (:func:`fuse_height`)
until a survey of the node takes its place.

A map is written to and read from a plain dictionary (:meth:`TrussMap.to_dict`,
:meth:`TrussMap.from_dict`), the survey file's content (docs/walking.md).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.kinematics import WalkerKinematics
from walker_core.truss import Truss
from walker_supervisor.core.step_geometry import BaseFrame

__all__ = ['NodeEstimate', 'TrussMap', 'SurveyFileError', 'SURVEY_FORMAT', 'survey_covariance',
           'fuse', 'fuse_height', 'node_frame_name', 'TRUSS_FRAME']

#: The frame the map's positions are in (the viz's world frame).
TRUSS_FRAME = 'truss'


def node_frame_name(node: str) -> str:
    """Return the TF frame of a node: ``node_<column>_<row>`` for ``n<column>_<row>``."""
    return 'node_' + node[1:]

#: The ``format`` entry of a survey file this module writes and reads.
SURVEY_FORMAT = 'walker-truss-survey-1'


class SurveyFileError(ValueError):
    """A survey file's content that cannot be read as a truss map."""


@dataclasses.dataclass(frozen=True)
class NodeEstimate:
    """One node's estimated place in the truss frame.

    Attributes
    ----------
    position : ndarray, shape (3,)
        Position [m] of the node's hole mouth in the truss frame.
    covariance : ndarray, shape (3, 3)
        Its covariance [m^2].
    surveyed : bool
        True once the joints have measured it (or it anchors the frame); False: nominal.
    """

    position: np.ndarray
    covariance: np.ndarray
    surveyed: bool

    @property
    def horizontal_std(self) -> float:
        """[m] standard deviation along the worst horizontal direction (the search's)."""
        return float(math.sqrt(max(np.linalg.eigvalsh(self.covariance[:2, :2]).max(), 0.0)))


def survey_covariance(kinematics: WalkerKinematics, theta_roles: np.ndarray, heading: float,
                      joint_std: np.ndarray) -> np.ndarray:
    """Covariance [m^2] in the truss frame of a tip measured through the joints.

    ``R J diag(joint_std^2) J^T R^T`` with ``J`` the position rows of the Jacobian of eq (1)
    at ``theta_roles`` [rad] and ``R`` the rotation by ``heading`` [rad] about z; ``joint_std``
    [rad] per joint, role order.
    """
    jac = kinematics.jacobian(theta_roles)[:3]
    c, s = math.cos(heading), math.sin(heading)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    jac_truss = rotation @ jac
    return jac_truss @ np.diag(np.asarray(joint_std, dtype=float) ** 2) @ jac_truss.T


def fuse(prior: NodeEstimate, measured: NodeEstimate) -> NodeEstimate:
    """Fuse two independent estimates of a node, weighted by their covariances.

    The Kalman (least-squares) update of ``prior`` by a direct measurement of the position:
    ``K = P (P + C)^-1``, ``x = x_p + K (x_m - x_p)``, covariance ``(I - K) P (I - K)^T
    + K C K^T`` (Joseph's form: symmetric and positive semi-definite). A prior with no
    uncertainty (the anchor) is kept; a measurement with none is taken as it is.

    Parameters
    ----------
    prior, measured : NodeEstimate
        Positions [m] and covariances [m^2] in the truss frame.

    Returns
    -------
    NodeEstimate
        The fused estimate, surveyed; its covariance no larger than either's.
    """
    p, c = prior.covariance, measured.covariance
    gain = p @ np.linalg.pinv(p + c, hermitian=True)
    rest = np.eye(3) - gain
    position = prior.position + gain @ (measured.position - prior.position)
    covariance = rest @ p @ rest.T + gain @ c @ gain.T
    return NodeEstimate(position, (covariance + covariance.T) / 2.0, True)


def fuse_height(estimate: NodeEstimate, height: float, variance: float) -> NodeEstimate:
    """Update an estimate by a measurement of its height alone (a scalar Kalman update).

    With ``h = (0, 0, 1)``: ``K = P h^T / (h P h^T + r)``, ``x = x + K (z - x_z)``, covariance
    ``(I - K h) P (I - K h)^T + K r K^T`` (Joseph's form).

    Parameters
    ----------
    estimate : NodeEstimate
        Position [m] and covariance [m^2] in the truss frame.
    height : float
        [m] The measured height ``z``.
    variance : float
        [m^2] Its variance ``r``.

    Returns
    -------
    NodeEstimate
        The updated estimate, its ``surveyed`` flag unchanged.
    """
    p = estimate.covariance
    total = float(p[2, 2] + variance)
    if total <= 0.0:
        return estimate  # both exact: nothing to weigh
    gain = p[:, 2] / total
    rest = np.eye(3)
    rest[:, 2] -= gain
    position = estimate.position + gain * (height - estimate.position[2])
    covariance = rest @ p @ rest.T + np.outer(gain, gain) * variance
    return NodeEstimate(position, (covariance + covariance.T) / 2.0, estimate.surveyed)


class TrussMap:
    """Every node's estimated place, nominal until the joints survey it.

    Parameters
    ----------
    truss : Truss
        The nominal truss (the parameter file).
    prior_std : float
        [m] standard deviation of a never surveyed node's place along x, y and z.
    joint_std : float or sequence of 5 float
        [rad] standard deviation of a joint's reading (offset and noise together), role order.
    """

    def __init__(self, truss: Truss, prior_std: float, joint_std) -> None:
        if not prior_std >= 0.0:
            raise ValueError(f'prior_std must be >= 0 m, got {prior_std}')
        std = np.broadcast_to(np.asarray(joint_std, dtype=float), (5,)).copy()
        if not np.all(std >= 0.0):
            raise ValueError(f'joint_std must be >= 0 rad, got {joint_std}')
        self.truss = truss
        self.prior_std = float(prior_std)
        self.joint_std = std
        self._surveyed: dict[str, NodeEstimate] = {}
        # per node, the base it was last surveyed from and the estimate before that survey
        self._prior: dict[str, tuple[str, NodeEstimate]] = {}
        # per node, its height felt by a descent: the base it was felt from, height [m] and
        # variance [m^2] (until a survey of the node takes its place)
        self._heights: dict[str, tuple[str, float, float]] = {}
        # per node, where a wrist camera saw its hole: x, y [m] and covariance [m^2] (until a
        # survey of the node takes its place)
        self._sightings: dict[str, NodeEstimate] = {}
        self.anchor: str = ''
        self.version = 0  # grows with every change: a publisher re-latches on it

    # ------------------------------------------------------------------ queries
    def estimate(self, node: str, seen: bool = True) -> NodeEstimate:
        """Return the node's estimate: surveyed, or predicted from the map (UnknownNodeError).

        A node not surveyed is predicted from the surveyed node that knows it best
        (:meth:`predicted`); in a map with no surveyed node it is nominal with the prior. A
        height felt on its face updates it; where a wrist camera located its hole since, that
        is the estimate (``seen`` False: the estimate without it, the looks' prior).
        """
        if seen and node in self._sightings:
            return self._sightings[node]
        known = self._surveyed.get(node) or self.predicted(node)
        felt = self._heights.get(node)
        if felt is not None:
            known = fuse_height(known, felt[1], felt[2])
        return known

    def nominal(self, node: str) -> NodeEstimate:
        """Return the node's nominal place with the prior ``prior_std`` (the truss's drawing)."""
        return NodeEstimate(self.truss.position(node), np.eye(3) * self.prior_std ** 2, False)

    def predicted(self, node: str) -> NodeEstimate:
        """Predict a node from the surveyed node that knows it best (its nominal place if none).

        From a surveyed node ``s`` the nominal vector between the two: ``x = x_s + (p_k -
        p_s)``, ``C = C_s + (d / spacing)^2 prior_std^2 I`` with ``d`` [m] the nominal distance
        between them (a neighbour is known relative to ``s`` to ``prior_std``; farther, the
        truss's own placement and the frame's heading error grow with the distance). Of the
        surveyed nodes, the one whose prediction has the smallest horizontal variance (the
        search's direction) is taken.

        Returns
        -------
        NodeEstimate
            Position [m] and covariance [m^2] in the truss frame, not surveyed.
        """
        nominal = self.truss.position(node)
        best = None
        for source, known in self._surveyed.items():
            if source == node:
                continue
            offset = nominal - self.truss.position(source)
            hops = float(np.linalg.norm(offset)) / self.truss.spacing
            covariance = known.covariance + np.eye(3) * (hops * self.prior_std) ** 2
            spread = float(np.linalg.eigvalsh(covariance[:2, :2]).max())
            if best is None or spread < best[0]:
                best = (spread, known.position + offset, covariance)
        if best is None:
            return self.nominal(node)
        return NodeEstimate(best[1], (best[2] + best[2].T) / 2.0, False)

    def position(self, node: str) -> np.ndarray:
        """[m] the node's estimated position in the truss frame."""
        return self.estimate(node).position.copy()

    def surveyed(self, node: str) -> bool:
        """Return True if the node's place has been measured (or it anchors the frame)."""
        return node in self._surveyed

    @property
    def surveyed_nodes(self) -> list[str]:
        """The surveyed nodes, in the truss's order."""
        return [n for n in self.truss.node_names if n in self._surveyed]

    # ------------------------------------------------------------------ updates
    def anchor_at(self, node: str) -> None:
        """Anchor the truss frame at ``node`` (its nominal place, no uncertainty) if unanchored.

        A map that has an anchor already (a survey loaded, an earlier walk) keeps it.
        """
        if self.anchor:
            return
        self.truss.index(node)
        self.anchor = node
        self._surveyed[node] = NodeEstimate(self.truss.position(node), np.zeros((3, 3)), True)
        self.version += 1

    def measure(self, node: str, frame: BaseFrame, base_node: str,
                kinematics: WalkerKinematics, theta_roles: np.ndarray) -> NodeEstimate:
        """Measure ``node`` from the joints, both grippers attached; the map is unchanged.

        Parameters
        ----------
        node : str
            The node the other gripper is screwed into.
        frame : BaseFrame
            The base gripper's frame in the truss frame (at ``base_node``).
        base_node : str
            The base gripper's node.
        theta_roles : ndarray, shape (5,)
            Measured joint angles J1..J5 [rad], role order of the base gripper.

        Returns
        -------
        NodeEstimate
            The forward kinematics' position [m] in the truss frame, with the base node's
            covariance plus the readings' through the Jacobian [m^2].
        """
        if node == base_node:
            raise ValueError(f'cannot survey the base node {node} from itself')
        self.truss.index(node)
        theta = np.asarray(theta_roles, dtype=float)
        position = frame.to_truss(kinematics.forward(theta)[:3])
        covariance = self.estimate(base_node).covariance + survey_covariance(
            kinematics, theta, frame.heading, self.joint_std)
        return NodeEstimate(position, covariance, True)

    def survey(self, node: str, frame: BaseFrame, base_node: str,
               kinematics: WalkerKinematics, theta_roles: np.ndarray) -> NodeEstimate:
        """Survey ``node`` from the joints, fused into the map (:meth:`measure`, :func:`fuse`).

        The prior is what the map knew of the node before it was surveyed from ``base_node``:
        surveyed from the same base again, the new reading replaces the last one.

        Returns
        -------
        NodeEstimate
            The new estimate (also kept; the anchor is never moved).
        """
        measured = self.measure(node, frame, base_node, kinematics, theta_roles)
        if node == self.anchor:
            return self.estimate(node)
        last_base, prior = self._prior.get(node, ('', None))
        if prior is None or last_base != base_node:
            # the nominal place, not the prediction from a surveyed node: the survey is taken
            # through that node already, and the drawing is what bounds the chain's drift
            prior = self._surveyed.get(node) or self.nominal(node)
            self._prior[node] = (base_node, prior)
        estimate = fuse(prior, measured)
        self._surveyed[node] = estimate
        # the survey measures the height and the place through the same joints
        self._heights.pop(node, None)
        self._sightings.pop(node, None)
        self.version += 1
        return estimate

    def estimates(self) -> list[tuple[str, NodeEstimate]]:
        """Return every node with its estimate (surveyed, or nominal), in the truss's order."""
        return [(n, self.estimate(n)) for n in self.truss.node_names]

    def measure_height(self, node: str, frame: BaseFrame, base_node: str,
                       kinematics: WalkerKinematics, theta_roles: np.ndarray,
                       above_mouth: float, contact_std: float) -> NodeEstimate:
        """Take the height of ``node``'s mouth felt by a descent resting on its face.

        The tip's height (forward kinematics of eq (1) of ``theta_roles`` [rad], role order
        of the base gripper, from ``frame`` at ``base_node``) less ``above_mouth`` [m] (how far
        above the mouth the gripper rests: the screw's length when its tip stands on the face
        beside the hole, 0 when it rests on the mouth) measures the mouth's height with the
        variance ``C_base,zz + (R J S J^T R^T)_zz + contact_std^2`` [m^2] (``contact_std`` [m]:
        how deep the gripper may press into the face or stand above it). The node's estimate
        takes it by the one-dimensional update of :func:`fuse_height`: its height moves, its
        x and y only as far as they are correlated with it. A later height felt replaces it
        (felt through the same joints, it is not a second measurement), and a survey of the
        node takes its place.

        Returns
        -------
        NodeEstimate
            The node's new estimate (the anchor is never moved).
        """
        if not (math.isfinite(above_mouth) and contact_std >= 0.0):
            raise ValueError(f'above_mouth must be finite and contact_std >= 0 m, got '
                             f'{above_mouth} and {contact_std}')
        if node == base_node:
            raise ValueError(f'cannot feel the base node {node} from itself')
        self.truss.index(node)
        if node == self.anchor:
            return self.estimate(node)
        theta = np.asarray(theta_roles, dtype=float)
        height = float(frame.to_truss(kinematics.forward(theta)[:3])[2]) - above_mouth
        variance = float(self.estimate(base_node).covariance[2, 2] + survey_covariance(
            kinematics, theta, frame.heading, self.joint_std)[2, 2] + contact_std ** 2)
        self._heights[node] = (base_node, height, variance)
        self._sightings.pop(node, None)  # the next look locates the hole at this height
        self.version += 1
        return self.estimate(node)

    def sight(self, node: str, frame: BaseFrame, base_node: str, kinematics: WalkerKinematics,
              theta_roles: np.ndarray, position: np.ndarray, covariance: np.ndarray
              ) -> NodeEstimate:
        """Take ``node``'s hole as the moving gripper's wrist camera located it.

        ``position`` [m] and ``covariance`` [m^2] are the hole's mouth in the base frame
        (``frame`` at ``base_node``) located by the looks from the map's estimate
        (:func:`~walker_supervisor.core.sighting.locate`): the estimate with the images. The
        camera sees the hole against the gripper, which the joints ``theta_roles`` [rad] (role
        order of the base) place: the tip's covariance through them (eq (1)'s Jacobian) and the
        base node's are added. It is the node's estimate until a later look, a height felt
        (which the next look takes up) or a survey of the node.

        Returns
        -------
        NodeEstimate
            The node's new estimate (the anchor is never moved).
        """
        if node == base_node:
            raise ValueError(f'cannot see the base node {node} from itself')
        self.truss.index(node)
        if node == self.anchor:
            return self.estimate(node)
        theta = np.asarray(theta_roles, dtype=float)
        c, s = math.cos(frame.heading), math.sin(frame.heading)
        rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        total = (rotation @ np.asarray(covariance, dtype=float) @ rotation.T
                 + self.estimate(base_node).covariance
                 + survey_covariance(kinematics, theta, frame.heading, self.joint_std))
        known = self.estimate(node, seen=False)
        self._sightings[node] = NodeEstimate(frame.to_truss(np.asarray(position, dtype=float)),
                                             (total + total.T) / 2.0, known.surveyed)
        self.version += 1
        return self.estimate(node)

    def frames(self) -> list[tuple[str, np.ndarray, bool]]:
        """Return every node's frame: its TF name, position [m] in the truss frame, surveyed."""
        return [(node_frame_name(n), e.position.copy(), e.surveyed)
                for n, e in ((n, self.estimate(n)) for n in self.truss.node_names)]

    # ------------------------------------------------------------------ the survey file
    def to_dict(self) -> dict:
        """Return the survey file's content: plain lists and floats (docs/walking.md)."""
        return {'format': SURVEY_FORMAT, 'frame': 'truss', 'anchor': self.anchor,
                'nodes': {n: {'position': [float(v) for v in e.position],
                              'covariance': [[float(v) for v in row] for row in e.covariance]}
                          for n, e in ((n, self._surveyed[n]) for n in self.surveyed_nodes)}}

    def load(self, content: dict) -> None:
        """Take the surveyed nodes of a survey file's content; raises SurveyFileError.

        Nothing changes if any entry is wrong.
        """
        if not isinstance(content, dict) or content.get('format') != SURVEY_FORMAT:
            raise SurveyFileError(f'a survey file must have format: {SURVEY_FORMAT}')
        nodes = content.get('nodes') or {}
        anchor = content.get('anchor') or ''
        if not isinstance(nodes, dict):
            raise SurveyFileError('the survey file\'s "nodes" must map node names to entries')
        taken = {}
        for node, entry in nodes.items():
            try:
                self.truss.index(node)
                position = np.asarray(entry['position'], dtype=float)
                covariance = np.asarray(entry['covariance'], dtype=float)
            except (KeyError, TypeError, ValueError) as error:
                raise SurveyFileError(f'survey entry {node!r}: {error}') from None
            if position.shape != (3,) or covariance.shape != (3, 3) \
                    or not np.all(np.isfinite(position)) or not np.all(np.isfinite(covariance)):
                raise SurveyFileError(f'survey entry {node!r}: position must be 3 finite '
                                      f'values [m] and covariance 3x3 [m^2]')
            if np.linalg.eigvalsh((covariance + covariance.T) / 2).min() < -1e-12:
                raise SurveyFileError(f'survey entry {node!r}: covariance is not positive '
                                      f'semi-definite')
            taken[node] = NodeEstimate(position, covariance, True)
        if anchor and anchor not in taken:
            raise SurveyFileError(f'the anchor {anchor!r} has no survey entry')
        self._surveyed = taken
        self._prior = {}
        self._heights = {}
        self._sightings = {}
        self.anchor = anchor
        self.version += 1

    @classmethod
    def from_dict(cls, truss: Truss, prior_std: float, joint_std, content: dict) -> 'TrussMap':
        """Return a map with a survey file's content (:meth:`load`)."""
        survey = cls(truss, prior_std, joint_std)
        survey.load(content)
        return survey
