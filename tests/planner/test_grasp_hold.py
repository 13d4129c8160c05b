"""The hold criterion of a two-finger grasp against closed forms (planner/grasp_hold.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.planner.grasp_hold import (
    G_M_S2,
    ContactPatch,
    disc_torsion_radius_m,
    hold_requirement,
    rectangle_torsion_radius_m,
)

RNG = np.random.default_rng(11)


def _uniform_rectangle(w: float, h: float, n: int = 200_000) -> np.ndarray:
    return RNG.uniform([-w / 2, -h / 2], [w / 2, h / 2], size=(n, 2))


def _uniform_disc(r: float, n: int = 200_000) -> np.ndarray:
    rho = r * np.sqrt(RNG.uniform(size=n))
    phi = RNG.uniform(0, 2 * math.pi, size=n)
    return np.stack([rho * np.cos(phi), rho * np.sin(phi)], axis=1)


def _line(length: float, n: int = 2001, along: int = 1) -> np.ndarray:
    p = np.zeros((n, 2))
    p[:, along] = np.linspace(-length / 2, length / 2, n)
    return p


def test_torsion_radius_closed_forms():
    # unit square (half sides 1/2): (2 a b d + a^3 ln((b+d)/a) + b^3 ln((a+d)/b)) / (6 a b)
    # = (sqrt 2 + ln(1 + sqrt 2)) / 6 = 0.38260..., the mean distance from a square's centre
    assert rectangle_torsion_radius_m(1.0, 1.0) == pytest.approx(
        (math.sqrt(2) + math.log(1 + math.sqrt(2))) / 6, rel=1e-12)
    assert rectangle_torsion_radius_m(0.0, 0.03) == pytest.approx(0.03 / 4, rel=1e-12)  # a line
    assert disc_torsion_radius_m(0.01) == pytest.approx(0.02 / 3, rel=1e-12)


@pytest.mark.parametrize("w,h", [(0.02, 0.03), (0.002, 0.03), (0.01, 0.01)])
def test_patch_torsion_radius_integrates_the_rectangle(w, h):
    """Uniform samples of a rectangle: the sample mean distance is the area integral (1 %)."""
    patch = ContactPatch(_uniform_rectangle(w, h), w * h)
    assert patch.torsion_radius_m == pytest.approx(rectangle_torsion_radius_m(w, h), rel=0.01)


def test_patch_torsion_radius_of_a_disc_is_two_thirds_of_its_radius():
    patch = ContactPatch(np.add(_uniform_disc(0.004), [0.01, -0.02]), math.pi * 0.004**2)
    assert patch.torsion_radius_m == pytest.approx(2 / 3 * 0.004, rel=0.01)
    np.testing.assert_allclose(patch.centroid_m, [0.01, -0.02], atol=2e-5)


M, MU, SF = 0.05, 0.5, 2.0
DOWN_IN_PLANE = (np.array([0.0, 0.0, -1.0]),)  # gravity along the approach (pads vertical)


def test_centred_grasp_needs_the_classic_slip_force():
    p = ContactPatch(_uniform_rectangle(0.02, 0.03, 20_000), 6e-4)
    com = np.array([p.centroid_m[0], 0.0, p.centroid_m[1]])  # on the contact centre
    for a in (0.0, 2.0, 20.0):
        req = hold_requirement(p, p, com, M, a, MU, SF, DOWN_IN_PLANE)
        assert req.required_N == pytest.approx(SF * M * (G_M_S2 + a) / (2 * MU), rel=1e-9)
        assert req.mechanism == "sliding"


def test_off_centre_grasp_on_line_contacts_turns_about_the_closing_axis():
    """Line contacts of length L along z, the centre of mass a lever d away along x, gravity
    along z in the pad plane (a = 0): moment m g d about the closing axis, resisted by
    2 mu F L / 4; with the load, F = sf / (2 mu) m g sqrt(1 + (d / (L / 4))^2)."""
    L, d = 0.02, 0.01
    line = ContactPatch(_line(L), 0.0)
    req = hold_requirement(line, line, np.array([d, 0.0, 0.0]), M, 0.0, MU, SF, DOWN_IN_PLANE)
    expected = SF / (2 * MU) * M * G_M_S2 * math.hypot(1.0, d / (L / 4))
    assert req.friction_N == pytest.approx(expected, rel=1e-3)
    assert req.required_N == pytest.approx(expected, rel=1e-3)
    assert req.mechanism == "turning about the closing axis"
    assert req.lever_m == pytest.approx(d, rel=1e-12)
    assert req.torsion_radius_m == pytest.approx(L / 4, rel=1e-3)


def test_lever_along_gravity_makes_no_moment_at_rest():
    """A dowel held at its top end, hanging: the lever is along gravity (a = 0)."""
    line = ContactPatch(_line(0.005), 0.0)
    req = hold_requirement(line, line, np.array([0.0, 0.0, -0.02]), M, 0.0, MU, SF,
                           DOWN_IN_PLANE)
    assert req.required_N == pytest.approx(SF * M * G_M_S2 / (2 * MU), rel=1e-9)


def test_tipping_about_the_contact_line_is_carried_by_the_patch_extent():
    """Closing axis vertical (gravity along it: carried by the lower pad), the centre of mass a
    lever d out along x: moment m g d about the pad plane's z axis; the centres of pressure of
    two s x s patches can move s apart along x: F = sf m g d / s. A line along z (no extent
    along x) cannot carry it at all."""
    s, d = 0.004, 0.03
    square = ContactPatch(_uniform_rectangle(s, s, 100_000), s * s)
    down_c = (np.array([0.0, -1.0, 0.0]),)
    req = hold_requirement(square, square, np.array([d, 0.0, 0.0]), M, 0.0, MU, SF, down_c)
    # the samples' extremes fall short of the square's edges by ~s / n
    assert req.tipping_N == pytest.approx(SF * M * G_M_S2 * d / s, rel=1e-3)
    assert req.mechanism == "tipping about the contact line"
    line = ContactPatch(_line(0.02), 0.0)
    assert math.isinf(hold_requirement(line, line, np.array([d, 0.0, 0.0]), M, 0.0, MU, SF,
                                       down_c).required_N)


def test_rigid_pad_on_a_cylinder_touches_a_line():
    """The samples within the contact band of a cylinder's flank (radius R, band b) span
    2 sqrt(2 R b) across its axis; a rigid flat pad touches the line only: the torsion radius
    is L / 4, not the band's. A flat face keeps its whole patch."""
    R, b, L = 0.01, 3e-4, 0.02
    half = math.sqrt(2 * R * b)
    p = _uniform_rectangle(2 * half, L, 5000)
    depth = R - np.sqrt(R**2 - p[:, 0] ** 2)
    keep = depth <= b
    patch = ContactPatch.rigid(p[keep], depth[keep], 0.0, b)
    assert patch.torsion_radius_m == pytest.approx(L / 4, rel=0.01)
    flat = ContactPatch.rigid(p, np.zeros(len(p)), 0.0, b)
    assert flat.torsion_radius_m == pytest.approx(rectangle_torsion_radius_m(2 * half, L),
                                                  rel=0.02)


def test_contact_tilted_from_the_squeeze_leaves_less_friction():
    """A pad's edge on a cylinder's shoulder, the normal tilted theta from the closing axis:
    the squeeze spends tan(theta) of the friction, mu_eff = tan(atan(mu) - theta)."""
    mu, theta = 0.7, math.radians(30)
    tilt = np.tile([math.tan(theta), 0.0], (5, 1))
    patch = ContactPatch.rigid(_line(0.01, 5), np.zeros(5), 0.0, 3e-4, tilt)
    assert patch.friction(mu) == pytest.approx(math.tan(math.atan(mu) - theta), rel=1e-12)
    flat = ContactPatch(_line(0.01, 5), 0.0)
    req_flat = hold_requirement(flat, flat, np.zeros(3), M, 0.0, mu, SF, DOWN_IN_PLANE)
    req = hold_requirement(patch, patch, np.zeros(3), M, 0.0, mu, SF, DOWN_IN_PLANE)
    assert req.required_N == pytest.approx(req_flat.required_N * mu / patch.friction(mu),
                                           rel=1e-9)
    steep = ContactPatch.rigid(_line(0.01, 5), np.zeros(5), 0.0, 3e-4, tilt * 2)  # 49 deg
    assert steep.friction(mu) == 0.0
    assert math.isinf(hold_requirement(steep, steep, np.zeros(3), M, 0.0, mu, SF,
                                       DOWN_IN_PLANE).required_N)


def test_line_contacts_hold_a_moment_about_the_line_by_the_friction_couple():
    """Two lines along x (a cylinder pinched across its diameter, its axis along x), the
    centre of mass a lever d beyond them along z, gravity along the closing axis: moment
    m g d about the lines. The normal forces cannot shift across a line (infinite without
    the width); the pads' friction, f_1 = -f_2 along z, makes the couple f w across the grip
    width w: each pad needs f = m g d / w <= mu F, so F = sf m g d / (mu w)."""
    d, w = 0.003, 0.02
    line = ContactPatch(_line(0.004, along=0), 0.0)
    down_c = (np.array([0.0, -1.0, 0.0]),)
    com = np.array([0.0, 0.0, d])
    assert math.isinf(hold_requirement(line, line, com, M, 0.0, MU, SF, down_c).required_N)
    req = hold_requirement(line, line, com, M, 0.0, MU, SF, down_c, width_m=w)
    assert req.required_N == pytest.approx(SF * M * G_M_S2 * d / (MU * w), rel=1e-9)
    # with the load in the pad plane as well (gravity along z: f_t = m g shared by both
    # pads, no moment): the classic slip force, the couple adding nothing
    down_z = (np.array([0.0, 0.0, -1.0]),)
    req_z = hold_requirement(line, line, com, M, 0.0, MU, SF, down_z, width_m=w)
    assert req_z.required_N == pytest.approx(SF * M * G_M_S2 / (2 * MU), rel=1e-9)
    # gravity along the closing axis and an acceleration a along z: each pad carries
    # m a / 2 along z plus the couple's m g d / w: F = sf m (a / 2 + g d / w) / mu
    a = 3.0
    req_a = hold_requirement(line, line, com, M, a, MU, SF, down_c, width_m=w)
    assert req_a.required_N >= SF * M * (a / 2 + G_M_S2 * d / w) / MU * (1 - 1e-9)
