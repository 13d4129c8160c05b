"""The exact feature-level fit contact (sim/fit_geometry.py, sim/feature_contact.py) against
closed forms: distances to the bore's and the pin's profiles, Whitney's two-point pose, the
least-distance solve, and, through the simulator, Whitney's jam depth at every tilt and the
capture boundary of an unchamfered pin (issues 16 and 17)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from asmplan.sim.contacts import Contacts
from asmplan.sim.feature_contact import least_distance
from asmplan.sim.fidelity import ACCURATE, BALANCED
from asmplan.sim.fit_geometry import BoreFeature, FitContactModel, PinFeature, revolved_sdf
from bench.scenarios import PinHole, entered_depth_m, jam_depth_m, pin_insertion, whitney_jam_depth_m

R, H = 5.05e-3, 20e-3  # bore radius, depth
UP = np.array([0.0, 0.0, 1.0])


def bore(chamfer_m: float = 0.0, through: bool = False) -> BoreFeature:
    return BoreFeature(np.zeros(3), UP, R, chamfer_m, H, through, R + 3e-3)


@pytest.mark.parametrize(("point", "gap"), [
    ((R - 1e-5, 0.0, -5e-3), 1e-5),  # inside the bore, 10 um off the wall
    ((R + 1e-3, 0.0, 2e-5), 2e-5),  # 20 um above the face
    ((0.0, R - 2e-3, -H + 3e-6), 3e-6),  # 3 um above a blind bore's floor
    ((R + 4e-6, 0.0, -1e-3), -4e-6),  # 4 um into the wall
    ((R + 3e-4, 0.0, 0.0), 2e-4 / math.sqrt(2)),  # over a 0.5 mm chamfer, 0.2 mm from its foot
])
def test_bore_profile_distances(point, gap):
    b = bore(0.5e-3) if point[0] == R + 3e-4 else bore()
    d, n = revolved_sdf(np.array([point]), b.profile())
    assert d[0] == pytest.approx(gap, abs=1e-10)
    assert np.linalg.norm(n[0]) == pytest.approx(1.0)


def test_pin_profile_distances():
    pin = PinFeature(np.zeros(3), UP, 5e-3, 0.5e-3, 20e-3)
    pts = np.array([[5e-3 + 7e-6, 0.0, 3e-3],  # 7 um off the side
                    [0.0, 1e-3, -2e-6],  # 2 um below the tip face
                    [4.5e-3 + 1e-6, 0.0, 0.0]])  # 1 um beyond the chamfer's foot
    d, _ = revolved_sdf(pts, pin.profile())
    assert d[0] == pytest.approx(7e-6, abs=1e-10)
    assert d[1] == pytest.approx(2e-6, abs=1e-10)
    assert d[2] == pytest.approx(1e-6 / math.sqrt(2), abs=1e-10)


def test_a_pin_in_the_corner_of_a_blind_bore_touches_its_floor():
    """A sharp pin 1 um smaller than its blind bore, 0.5 um off the wall on one side, its tip
    3 um above the floor: near the wall the tip circle's nearest face is the wall, elsewhere
    the floor, so the point-to-solid distance alone gave the wall point only (the floor's
    samples were a plateau, no local minimum) and nothing held the pin up (a pin seated on
    a floor sank and was lifted back by the position projection every step while its
    velocity grew at g). Both faces of the concave corner are active: the contact holds the
    wall point and floor points (normal +z, gap 3 um) round the circle."""
    pin = PinFeature(np.zeros(3), UP, R - 1e-6, 0.0, 15e-3)
    model = FitContactModel(pin, bore())
    T_pin = np.eye(4)
    T_pin[:3, 3] = (0.5e-6, 0.0, -H + 3e-6)
    fc = model.contacts(T_pin, np.eye(4), 5e-6)
    wall = np.abs(fc.normal[:, 2]) < 1e-9
    assert float(np.min(fc.gap_m[wall])) < 1e-6  # the wall side
    floor = np.abs(fc.normal[:, 2] - 1.0) < 1e-12
    assert np.count_nonzero(floor) >= 3
    assert fc.gap_m[floor] == pytest.approx(3e-6, abs=1e-9)
    assert np.all(np.abs(fc.point_m[floor, 2] + H) < 1e-12)  # on the floor


def whitney_pose(d: float, D: float, t: float, extra_m: float = 0.0) -> np.ndarray:
    """The pin frame (tip at the origin, z toward the root) of a pin tilted by t whose leading
    corner touches the wall at x = +D/2 and whose trailing side touches the mouth edge at
    x = -D/2: the tip lies l* = (D - d cos t) / sin t along the axis below the mouth;
    ``extra_m`` pushes it further along -z."""
    r = d / 2.0
    u = np.array([-math.sin(t), 0.0, math.cos(t)])
    e = np.array([math.cos(t), 0.0, math.sin(t)])
    lstar = (D - d * math.cos(t)) / math.sin(t)
    tip = np.array([D / 2.0 - r * math.cos(t), 0.0, -lstar * math.cos(t) + r * math.sin(t)])
    T = np.eye(4)
    T[:3, :3] = np.column_stack([e, np.cross(u, e), u])
    T[:3, 3] = tip - np.array([0.0, 0.0, extra_m])
    return T


@pytest.mark.parametrize(("c", "t_deg"), [(0.05e-3, 0.5), (0.1e-3, 2.0), (0.5e-3, 5.0)])
def test_whitney_two_point_pose_touches_both_walls(c, t_deg):
    """At Whitney's pose both contacts have zero gap (to 1e-9 m); 1 um deeper along the
    insertion the pin penetrates by exactly 1 um x sin t at the mouth (the wedge blocks it);
    1 um higher it is free."""
    d, D, t = 10e-3, 10e-3 + c, math.radians(t_deg)
    model = FitContactModel(PinFeature(np.zeros(3), UP, d / 2, 0.0, 30e-3),
                            BoreFeature(np.zeros(3), UP, D / 2, 0.0, 40e-3, False, D / 2 + 3e-3))
    at = model.contacts(whitney_pose(d, D, t), np.eye(4), 20e-6)
    walls = at.normal[:, 0] < -0.99  # the +x wall pushes the leading corner back
    mouth = at.normal[:, 0] > 0.99  # the mouth edge pushes the trailing side
    assert np.min(np.abs(at.gap_m[walls])) < 1e-9 and np.min(np.abs(at.gap_m[mouth])) < 1e-9
    # 1 um down along -z: the mouth edge enters the pin's side by 1 um x sin t
    deeper = model.contacts(whitney_pose(d, D, t, 1e-6), np.eye(4), 20e-6)
    assert np.min(deeper.gap_m) == pytest.approx(-1e-6 * math.sin(t), rel=0.01)
    assert np.min(model.contacts(whitney_pose(d, D, t, -1e-6), np.eye(4), 20e-6).gap_m) > -1e-12


def test_least_distance_matches_a_qp():
    rng = np.random.default_rng(3)
    for _ in range(20):
        G = rng.normal(size=(5, 6))
        h = rng.normal(size=5)
        y, lam = least_distance(G, h)
        ref = minimize(lambda x: 0.5 * x @ x, np.zeros(6), jac=lambda x: x, method="SLSQP",
                       constraints=[{"type": "ineq", "fun": lambda x, G=G, h=h: G @ x - h,
                                     "jac": lambda x, G=G: G}], options={"ftol": 1e-14})
        assert np.allclose(y, ref.x, atol=1e-6)
        assert np.all(G @ y - h > -1e-9) and np.all(lam >= 0)
        assert np.allclose(G.T @ lam, y, atol=1e-9)


def test_least_distance_of_a_near_opposed_wedge():
    """Two constraints whose normals are 0.5 deg from opposed (the 0.5 deg jam's wedge,
    condition ~ 4 / t^2): solved exactly."""
    t = math.radians(0.5)
    G = np.array([[-1.0, 0.0], [math.cos(t), math.sin(t)]])
    y, _ = least_distance(G, np.array([0.0, 1.0]))
    assert np.all(G @ y >= np.array([0.0, 1.0]) - 1e-9)
    assert y[0] == pytest.approx(0.0, abs=1e-9) and y[1] == pytest.approx(1 / math.sin(t))


@pytest.mark.slow
@pytest.mark.parametrize("c_mm", [0.05, 0.1, 0.5])
@pytest.mark.parametrize("t_deg", [0.5, 1.0, 2.0, 5.0])
def test_jam_depth_within_0_1_mm_at_balanced_at_every_tilt(c_mm, t_deg):
    """Issue 16's done-when: Whitney's l* within 0.1 mm at BALANCED for c >= 0.05 mm and
    t = 0.5-5 deg (where l* fits the 20 mm hole). Measured: |error| <= 2.5 um (Bullet's own
    contact: +3.3 mm at 0.5 deg)."""
    c, t = c_mm * 1e-3, math.radians(t_deg)
    ref = whitney_jam_depth_m(c, t)
    if ref > 0.018:
        pytest.skip(f"l* = {ref * 1e3:.1f} mm is deeper than the hole")
    assert abs(jam_depth_m(BALANCED, c, t) - ref) < 0.1e-3


_CAPTURE_012_BALANCED = (
    "issues 16/17, measured (session 9, docs/physics.md 'Exact fit contact', Open): at "
    "BALANCED the pin lands 0.118 mm off (c/2 = 0.1 mm) on the rim crescent at 62 mm/s "
    "and stops there (rim_stop, entered 0.016 mm), but the robot's push slides it "
    "6.7 mm up the pads (slip > 2 mm) and the eccentric rim reaction tilts it 0.5 deg "
    "in the sliding grip within 10 ms; it slides off the 18 um crescent and drops "
    "13 mm in. The pads' normals as rows of the fit solve (sim/grip_pads.py) stop it on "
    "the rim, but they are off at BALANCED (Fidelity.grip_rows: with them the bundled "
    "peg jams at 0.1 mm pose errors); ACCURATE (rows on) stops on the rim")


@pytest.mark.slow
@pytest.mark.parametrize(("fid", "offset_mm", "goes_in"), [
    pytest.param(f, off, ins, id=f"{off}-{ins}-{f.name}",
                 marks=(pytest.mark.xfail(strict=True, reason=_CAPTURE_012_BALANCED)
                        if (f.name, off) == ("balanced", 0.12) else ()))
    for f in (BALANCED, ACCURATE) for off, ins in ((0.5, False), (0.12, False), (0.08, True))])
def test_capture_boundary_of_an_unchamfered_pin(fid, offset_mm, goes_in):
    """|e0| < c/2 (no chamfer; c/2 = 0.1 mm): 0.08 mm off goes in, 0.12 and 0.5 mm off stay
    on the rim. ACCURATE's 0.5 mm case tipped in (7.67 mm) with Bullet's own contact."""
    # the pipeline's gripper (synchronised jaws): the scene's floating jaws held the pin
    # 0.100 mm off-centre along the closing axis at BALANCED, beyond the case's own offset
    record, outcome = pin_insertion(fid, 0.1e-3, lateral_offset_m=offset_mm * 1e-3,
                                    scene=PinHole(coupled_gripper=True))
    if goes_in:
        assert outcome.success, outcome.reasons
        assert entered_depth_m(record) > 19e-3
    else:
        assert not outcome.success
        assert entered_depth_m(record) < 0.2e-3
        assert next(f.code for f in outcome.failures) == "rim_stop"


def test_least_distance_finds_an_infeasible_set_at_large_multipliers():
    """The grip rows' normal solve of the gearbox shaft entering bearing_1 on its prism jaws
    (BALANCED, 11.014 s; 26 rows: its V pads and the bores over-constrain it), infeasible
    (HiGHS): the NNLS residual's round-off there is 2e-11 at multipliers of 3e4, which an
    absolute 1e-12 test took for feasible (y then round-off over round-off)."""
    from scipy.optimize import linprog

    data = np.load(Path(__file__).resolve().parents[1] / "fixtures" / "ldp_infeasible_shaft.npz")
    G, h = data["G"], data["h"]
    assert linprog(np.zeros(G.shape[1]), A_ub=-G, b_ub=-h,
                   bounds=[(None, None)] * G.shape[1]).status == 2  # infeasible
    assert least_distance(G, h) is None
    # made feasible (targets lowered by 10): solved, each row met
    y, lam = least_distance(G, h - 10.0)
    assert np.all(G @ y >= h - 10.0 - 1e-9) and np.all(lam >= 0)


def _two_pads(spread_m: float, normal_N: float) -> Contacts:
    """Two pads at y = +-20 mm, normals along y onto the part, each holding it at two points
    +-``spread_m`` along x with ``normal_N`` each, no friction used."""
    x = np.array([spread_m, -spread_m, spread_m, -spread_m])
    y = np.array([20e-3, 20e-3, -20e-3, -20e-3])
    p = np.column_stack([x, y, np.zeros(4)])
    n = np.array([[0, -1.0, 0], [0, -1.0, 0], [0, 1.0, 0], [0, 1.0, 0]])
    return Contacts(np.zeros(4, dtype=int), np.zeros(4, dtype=int), np.array([0, 0, 1, 1]), p, p,
                    n, np.zeros(4), np.full(4, normal_N), np.zeros((4, 3)))


def test_grip_utilisation_against_the_pads_analytic_capacities():
    """The grip's holding capacity (feature_contact.grip_utilisation) per load: a moment about
    the closing axis against the pads' torsion mu N rho x 2 (rho their points' spread), a force
    across it against mu sum N, a moment across it against mu N_min d; shares add."""
    from asmplan.sim.feature_contact import grip_utilisation

    mu, spread, N = 0.75, 4.5e-3, 34.25
    pads = _two_pads(spread, N)
    torsion = 2 * mu * (2 * N) * spread  # 0.462 N m
    # a couple of 0.1 N m about y: +-F along z at x = +-10 mm
    F = 0.1 / 0.02
    f = np.array([[0, 0, -F], [0, 0, F]])
    p = np.array([[10e-3, 0, 0], [-10e-3, 0, 0]])
    assert grip_utilisation(pads, mu, f, p) == pytest.approx(0.1 / torsion, rel=1e-12)
    # 10 N across the closing axis through the pads' centre
    assert grip_utilisation(pads, mu, np.array([[10.0, 0, 0]]), np.zeros((1, 3))) == (
        pytest.approx(10.0 / (mu * 4 * N), rel=1e-12))
    # 0.5 N m about x (across the closing axis): opposite friction on pads 40 mm apart
    f = np.array([[0, 0, 25.0], [0, 0, -25.0]])
    p = np.array([[0, 10e-3, 0], [0, -10e-3, 0]])
    assert grip_utilisation(pads, mu, f, p) == pytest.approx(0.5 / (mu * 2 * N * 0.04), rel=1e-12)
    # a pad held at one point has no torsion: any moment about the closing axis is beyond it
    one = _two_pads(0.0, N)
    f = np.array([[0, 0, -1e-3], [0, 0, 1e-3]])
    assert grip_utilisation(one, mu, f, np.array([[1e-3, 0, 0], [-1e-3, 0, 0]])) == math.inf


def test_fit_with_pad_friction_yields_at_the_pads_capacity():
    """sim/fit_grip_qp.py: a 1 kg body driven at 10 mm/s by its pads into a wall (a fit row at
    its centre, gap 0) cannot both stick and stay out: the pads slide at their bound (the
    square inscribed in Coulomb's disc, c / sqrt 2 along the slip) and the wall takes the body's
    momentum plus that, lambda = m v + c / sqrt 2, the body stopped. Clear of the wall the pads
    hold it to the gripper's velocity; a free body against the wall is the least-distance
    solve's."""
    from asmplan.sim.fit_grip_qp import solve_fit_with_pad_friction

    v, dt, cap = 0.01, 1e-3, 0.004  # m/s, s, N s
    u = np.array([v, 0, 0, 0, 0, 0])
    Jn = np.array([[-1.0, 0, 0, 0, 0, 0]])
    Jt = np.array([[[0, 1.0, 0, 0, 0, 0], [0, 0, 1.0, 0, 0, 0]]])
    P = np.array([[[1.0, 0, 0, 0, 0, 0], [0, 0, 1.0, 0, 0, 0]]])  # the pad at the centre
    v_pad = np.array([[v, 0.0]])
    args = (Jt, np.array([0.5]), np.array([True]), P, v_pad, np.array([cap]), u, np.eye(6), dt)
    u_new, lam, _ = solve_fit_with_pad_friction(Jn, np.zeros(1), *args)
    assert lam[0] == pytest.approx(1.0 * v + cap / math.sqrt(2.0), rel=1e-5)
    assert abs(u_new[0]) < 1e-7  # stopped at the wall (the regularisation's eps p)
    # clear of the wall by more than a step's travel: held to the gripper, no wall impulse
    u_new, lam, _ = solve_fit_with_pad_friction(Jn, np.array([1e-3]), *args)
    assert lam[0] == 0.0 and u_new[0] == pytest.approx(v, rel=1e-6)
    # no pad: the least-distance solve of the fit alone
    none = (Jt, np.array([0.5]), np.array([True]), np.zeros((0, 2, 6)), np.zeros((0, 2)),
            np.zeros(0), u, np.eye(6), dt)
    u_new, lam, _ = solve_fit_with_pad_friction(Jn, np.zeros(1), *none)
    assert lam[0] == pytest.approx(v, rel=1e-5) and abs(u_new[0]) < 1e-7
