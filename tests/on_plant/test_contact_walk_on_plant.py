"""A headless walk screws into a node that sits lower or higher than the parameter file says.

The target node's true place is 1.5 mm below or above its nominal one (the truss as built; the
walker's model, the parameter file, does not know it). The descent is commanded
``supervisor.insertion_overtravel`` past the nominal mouth and the node's face stops it where
the node really is: the low node is still reached (not left hanging above its mouth), the high
one is not passed through. Both are screwed into at the first attempt, and the supervisor says
where it felt the face. One step each, the whole stack headless in sim time (a few seconds of
CPU each).
"""

import pytest

from walker_config.core.configuration import load_configuration
from walker_headless.runner import walk
from walker_sim.core.imperfections import NodePlacement
from walker_sim.core.plant import WalkerPlant

TARGET = 'n1_2'
HEIGHT_ERROR = 0.0015  # [m]


@pytest.fixture(scope='module')
def configuration():
    return load_configuration()


@pytest.mark.parametrize('height_error', [-HEIGHT_ERROR, HEIGHT_ERROR])
def test_a_node_off_its_height_is_reached_and_screwed_into(configuration, monkeypatch,
                                                            height_error):
    placed = NodePlacement.__init__

    def target_off_in_height(self, names, standard_deviation, seed):
        placed(self, names, standard_deviation, seed)
        self._errors = {TARGET: (0.0, 0.0, height_error)}

    monkeypatch.setattr(NodePlacement, '__init__', target_off_in_height)
    screwed = WalkerPlant.screw_in
    alignments = []  # the plant's own measure of each screw-in: the truth, not the estimate

    def screw_in(self, gripper):
        alignments.append(self.state().grippers[gripper].alignment)
        return screwed(self, gripper)

    monkeypatch.setattr(WalkerPlant, 'screw_in', screw_in)
    said = []
    result = walk(configuration, TARGET, say=lambda level, text: said.append(text))
    assert result.reached, result.message
    (report,) = result.reports
    assert report.success and report.insertion_attempts == 1
    # screwed in on the node's mouth: within the bore's clearance of the hole, in 3-D (a
    # descent to the nominal mouth would leave a low node's gripper 1.5 mm above it)
    assert [a.node for a in alignments] == [TARGET]
    assert alignments[0].position_error < 1e-3
    felt = [text for text in said if "met the node's face" in text]
    assert len(felt) == 1
    where = 'below' if height_error < 0 else 'above'
    # the face felt within a few tenths of a millimetre of where the node is (the contact's
    # give and the links' bend under the press)
    depth = float(felt[0].split(' mm ')[0].split()[-1])
    assert f'mm {where} the nominal mouth' in felt[0]
    assert depth == pytest.approx(abs(height_error) * 1e3, abs=0.3)  # [mm]
