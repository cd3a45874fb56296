"""The paper's section 4 reproduced: eq (14), Routh-Hurwitz (15)/(16), Figure 5, Figure 6.

One module per topic, each ROS-free and importable: :mod:`.routh` (eq (15) against the poles),
:mod:`.bode` (Figure 5), :mod:`.design` (the stability check of a parameter file),
:mod:`.figure6` (the Figure 6 experiment on any plant core), :mod:`.floor` (joint 1's fastest
sweeps); :mod:`.command` is the ``control_analysis`` command line.
"""
