"""The two-point contact evidence of a jammed insertion (sim/verdicts.two_point_contacts)."""

from __future__ import annotations

import numpy as np

from asmplan.sim.verdicts import ContactEvidence, Failure, classify_insertion, two_point_contacts


def test_two_point_contacts_pick_the_most_loaded_point_on_each_side_of_the_axis():
    axis = np.array([0.0, 0.0, -1.0])
    centre = np.array([0.0, 0.0, 0.02])
    names = ["block", "block", "block", "block", "ground"]
    pos = np.array([[-0.005, 0.0, 0.030],   # mouth, -x side, 6 N
                    [-0.005, 0.001, 0.030],  # mouth, -x side, 2 N
                    [0.005, 0.0, 0.022],     # wall, +x side, 5 N
                    [0.005, 0.0, 0.021],     # wall, +x side, unloaded
                    [0.0, 0.0, 0.0]])        # on the axis: neither side
    normals = np.array([[1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0], [-1.0, 0, 0], [0, 0, 1.0]])
    force = np.array([6.0, 2.0, 5.0, 0.0, 1.0])
    a, b = two_point_contacts(names, pos, normals, force, centre, axis)
    assert (a.side, a.normal_force_N, a.position_m) == ("a", 6.0, (-0.005, 0.0, 0.030))
    assert (b.side, b.normal_force_N, b.position_m) == ("b", 5.0, (0.005, 0.0, 0.022))
    f = classify_insertion(8e-3, 20e-3, 0.5e-3, 0.05, 0.1e-3, (a, b), axis)
    assert f.code == "jammed"
    assert "two-point contact 8.00 mm apart along the axis" in f.message
    back = Failure.from_dict(f.to_dict())
    assert back.contacts == (a, b)


def test_one_sided_contact_is_said_so():
    axis = np.array([0.0, 0.0, -1.0])
    one = two_point_contacts(["block"], np.array([[0.005, 0.0, 0.02]]),
                             np.array([[-1.0, 0.0, 0.0]]), np.array([3.0]),
                             np.zeros(3), axis)
    assert len(one) == 1 and isinstance(one[0], ContactEvidence)
    assert "one-sided contact" in classify_insertion(5e-3, 20e-3, 0.5e-3, 0.0, 0.0, one,
                                                     axis).message
    assert two_point_contacts([], np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0),
                              np.zeros(3), axis) == ()
