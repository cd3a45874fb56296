"""A jam on a node's face tells the truss map the node's height, before the search finds it.

The target node sits 4 mm off its nominal place across the truss and 2.5 mm under it: more
than the insertion tolerance sideways, more than ``supervisor.insertion_overtravel`` down. The
first screw-in jams with the screw's tip on the face beside the hole; the joints there give the
node's height (the shoulder stands ``gripper.screw_length`` above the mouth), which the map
takes before the search goes on to find the hole. One step, the whole stack headless in sim
time.
"""

import numpy as np
import pytest

from walker_config.core.configuration import load_configuration
from walker_headless.runner import walk
from walker_sim.core.imperfections import NodePlacement
from walker_supervisor.core.map_planning import MapPlanning

TARGET = 'n1_2'
OFF = (0.004, 0.0, -0.0025)  # [m] the target's placement error


def test_a_jam_on_the_face_sets_the_nodes_height_in_the_map(monkeypatch):
    placed = NodePlacement.__init__

    def target_off(self, names, standard_deviation, seed):
        placed(self, names, standard_deviation, seed)
        self._errors = {TARGET: OFF}

    monkeypatch.setattr(NodePlacement, '__init__', target_off)
    felt = MapPlanning.felt_face
    heights = []  # (before, after) the map's height of the target [m], at each felt jam

    def felt_face(self, step, frame, theta_roles):
        before = self.map.estimate(step.to_node)
        felt(self, step, frame, theta_roles)
        heights.append((before, self.map.estimate(step.to_node)))

    monkeypatch.setattr(MapPlanning, 'felt_face', felt_face)
    result = walk(load_configuration(), TARGET)
    assert result.reached, result.message
    (report,) = result.reports
    assert report.success and report.search_probes >= 1
    assert heights, 'no jam was felt on the face'
    before, after = heights[0]
    # the map believed the drawing's height to 2 mm; it now has the node's to a few tenths
    assert abs(before.position[2] - OFF[2]) > 0.002
    assert after.position[2] == pytest.approx(OFF[2], abs=5e-4)
    assert np.sqrt(after.covariance[2, 2]) < 0.25 * np.sqrt(before.covariance[2, 2])
    assert not after.surveyed
