"""The exact fit contact's clearance proof on Python floats (sim/fit_clear.py): the analytic
clearance of a concentric pin, soundness against the detection it stands for, and the same
decisions as the numpy formulation it replaced."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.knowledge.frames import rotation_about
from asmplan.sim.fit_geometry import BoreFeature, FitContactModel, PinFeature
from asmplan.sim.fit_samples import SKIP_BAND_M, circle_extents

UP = np.array([0.0, 0.0, 1.0])
R_PIN, CLEARANCE, CHAMFER, DEPTH = 4e-3, 8.5e-6, 0.5e-3, 10e-3


def model(seat_radius_m: float = 0.0, through: bool = False) -> FitContactModel:
    """An 8 mm pin (0.5 mm chamfer, 8 mm long) over a bore 8.5 um larger in radius."""
    pin = PinFeature(np.zeros(3), UP, R_PIN, CHAMFER, 8e-3, seat_radius_m)
    bore = BoreFeature(np.zeros(3), UP, R_PIN + CLEARANCE, CHAMFER, DEPTH, through,
                       R_PIN + 6e-3)
    return FitContactModel(pin, bore)


def pose(x: float, y: float, z: float, tilt_rad: float = 0.0, azimuth: float = 0.0
         ) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rotation_about(np.array([-math.sin(azimuth), math.cos(azimuth), 0.0]),
                               tilt_rad)
    T[:3, 3] = (x, y, z)
    return T


def numpy_clear_of(m: FitContactModel, T_pin: np.ndarray, T_bore: np.ndarray, margin_m: float,
                   gap_m: float) -> bool:
    """The proof as it was written on numpy arrays before sim/fit_clear.py (the reference)."""
    Tp, Tb = m.frames(T_pin, T_bore)
    zb = Tb[:3, 2]
    tip_z = float(zb @ (Tp[:3, 3] - Tb[:3, 3]))
    ax_z = float(zb @ Tp[:3, 2])
    lean = math.sqrt(max(0.0, 1.0 - ax_z * ax_z))
    if min(tip_z + s * ax_z - rad * lean for s, rad in m._pin_circles) > margin_m:
        return True
    rel = Tp[:3, 3] - Tb[:3, 3]
    if float(np.linalg.norm(rel - (zb @ rel) * zb)) > m._far + m.pin.length_m * lean + margin_m:
        return True
    need = gap_m + SKIP_BAND_M
    Rp, pp, Rb, pb = Tp[:3, :3], Tp[:3, 3], Tb[:3, :3], Tb[:3, 3]
    pin = circle_extents(Rp, pp, *m._circle_arrays[True], Rb, pb)
    if float(np.min(m._bore_bound.lower_box(*pin[:4]))) < need or (
            not m.bore.through and float(np.min(pin[2])) < need - m.bore.depth_m):
        return False
    bore = circle_extents(Rb, pb, *m._circle_arrays[False], Rp, pp)
    if float(np.min(m._pin_bound.lower_box(*bore[:4]))) < need:
        return False
    for on_pin, ecc in ((True, pin[4]), (False, bore[4])):
        own = np.asarray(m._pin_vertex if on_pin else m._bore_vertex) >= 0
        e, r = ecc[own, None], m._circle_arrays[on_pin][1][own, None]
        other = m._bore_profile if on_pin else m._pin_profile
        rv = other.polygon[other.vertex_convex, 0][None, :]
        if np.any((e > np.abs(rv - r) - SKIP_BAND_M) & (e < rv + r + SKIP_BAND_M)):
            return False
    return True


def test_a_concentric_pin_in_its_bore_is_proved_clear_up_to_its_radial_clearance():
    """Concentric, 5 mm deep: the nearest points are the pin's chamfer circle and the bore's
    chamfer foot, both 8.5 um from the other solid; the proof holds for any gap below that
    (less its 1 nm band) and not above."""
    m = model()
    T_pin = pose(0.0, 0.0, -5e-3)
    fc = m.contacts(T_pin, np.eye(4), 50e-6)
    assert float(np.min(fc.gap_m)) == pytest.approx(CLEARANCE, abs=1e-12)
    assert m.clear_of(T_pin, np.eye(4), 50e-6, CLEARANCE - 2e-9)
    assert not m.clear_of(T_pin, np.eye(4), 50e-6, CLEARANCE)
    # 3 um off the axis: 5.5 um left on the near side
    T_off = pose(3e-6, 0.0, -5e-3)
    assert m.clear_of(T_off, np.eye(4), 50e-6, 5.5e-6 - 2e-9)
    assert not m.clear_of(T_off, np.eye(4), 50e-6, 5.5e-6)
    # 40 mm above the face: apart
    assert m.clear_of(pose(0.0, 0.0, 40e-3), np.eye(4), 50e-6, 0.1e-6)


@pytest.mark.parametrize(("seat", "through"), [(0.0, False), (6e-3, False), (0.0, True)])
def test_the_proof_is_sound_and_decides_as_the_numpy_formulation(seat, through):
    """Random poses round the mouth and down the bore (offsets to 30 um, tilts to 0.3 deg,
    seeded): wherever the proof holds, every contact the detection returns has a gap above
    the threshold; and it decides as the numpy formulation it replaced, pose for pose."""
    m = model(seat, through)
    rng = np.random.default_rng(7)
    T_bore = pose(0.01, -0.02, 0.03, 0.002, 0.7)
    held = refused = 0
    for _ in range(600):
        z = rng.uniform(-8e-3, 0.3e-3)
        offset = rng.uniform(0.0, 30e-6)
        az = rng.uniform(0.0, 2.0 * math.pi)
        T_rel = pose(offset * math.cos(az), offset * math.sin(az), z,
                     rng.uniform(0.0, math.radians(0.3)), rng.uniform(0.0, 2.0 * math.pi))
        T_pin = T_bore @ T_rel
        margin = rng.uniform(50e-6, 100e-6)
        gap = float(rng.choice([0.0, 0.1e-6, 2e-6]))
        proved = m.clear_of(T_pin, T_bore, margin, gap)
        assert proved == numpy_clear_of(m, T_pin, T_bore, margin, gap)
        if proved:
            held += 1
            fc = m.contacts(T_pin, T_bore, margin)
            assert fc.count == 0 or float(np.min(fc.gap_m)) > gap
        else:
            refused += 1
    assert held > 100 and refused > 100  # both outcomes exercised


def _records_equal(a, b) -> bool:
    import dataclasses
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            if x.shape != y.shape or not np.array_equal(x, y, equal_nan=True):
                return False
        elif f.name != "wall_time_s" and x != y:
            return False
    return True


def test_a_reuse_decided_without_its_detection_changes_nothing(monkeypatch):
    """A pin carried into its bore (10 um radial clearance, BALANCED, the pipeline's
    gripper): with the deferred detections' reuse decided by proof (DeferredReuse) the step's
    record and outcome are bit for bit those with every such detection made, and the proof
    did decide steps (otherwise this test would compare nothing)."""
    from asmplan.sim.fidelity import BALANCED
    from asmplan.sim.fit_clear import DeferredReuse
    from bench.scenarios import PinHole, pin_insertion

    decided = []
    original = DeferredReuse.stands

    def counting(self, *args):
        T = original(self, *args)
        decided.append(T is not None)
        return T

    monkeypatch.setattr(DeferredReuse, "stands", counting)
    record, outcome = pin_insertion(BALANCED, 10e-6, scene=PinHole(coupled_gripper=True))
    assert sum(decided) > 20
    monkeypatch.setattr(DeferredReuse, "stands", lambda self, *args: None)
    record_0, outcome_0 = pin_insertion(BALANCED, 10e-6, scene=PinHole(coupled_gripper=True))
    assert outcome.success and outcome_0.success
    assert outcome.reasons == outcome_0.reasons
    assert _records_equal(record, record_0)
