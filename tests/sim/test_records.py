"""Records, outcome and the success criteria (sim/records.py, execute.judge)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from asmplan.planner.trajectory import PhaseSpan, Trajectory
from asmplan.sim.execute import judge, scene_warnings
from asmplan.sim.records import StepRecord, SuccessCriteria

PHASES = (
    PhaseSpan("clamp", 0.0, 0.1),
    PhaseSpan("hold", 0.1, 0.2),
    PhaseSpan("lift", 0.2, 0.3),
    PhaseSpan("lower", 0.3, 0.4),
)


def trajectory() -> Trajectory:
    t = np.linspace(0.0, 0.4, 41)
    T = np.repeat(np.eye(4)[None], t.size, axis=0)
    T[:, 2, 3] = np.where(t < 0.2, 0.0, np.where(t < 0.3, (t - 0.2), 0.1 - (t - 0.3)))
    return Trajectory(t_s=t, T_world_gripper=T, clamp_force_N=np.full(t.size, 2.0), phases=PHASES)


def clean_record(n: int = 40) -> dict:
    t = np.linspace(0.01, 0.4, n)
    idx = np.searchsorted([p.t_start_s for p in PHASES], t, side="right") - 1
    T = np.repeat(np.eye(4)[None], n, axis=0)
    return {
        "phase_names": tuple(p.name for p in PHASES),
        "t_s": t,
        "phase_index": idx,
        "commanded_force_N": np.full(n, 2.0),
        "measured_force_N": np.full((n, 2), 2.0),
        "slip_m": np.zeros(n),
        "slip_rad": np.zeros(n),
        "T_world_part": T,
        "T_world_gripper": T.copy(),
        "finger_travel_m": np.full((n, 2), 0.01),
        "axial_error_m": np.full(n, np.nan),
        "lateral_error_m": np.full(n, np.nan),
        "external_force_N": np.zeros((n, 3)),
        "max_penetration_m": np.zeros(n),
        "speed_mps": np.zeros(n),
        "kinetic_energy_J": np.zeros(n),
    }


def run(**changes):
    rec = clean_record()
    rec.update(changes)
    return judge(StepRecord(**rec), trajectory(), SuccessCriteria(), part_mass_kg=0.1, T_world_part_target=np.eye(4))


def test_a_clean_record_succeeds():
    out = run()
    assert out.success and out.reasons == ()
    assert out.clamp_force_mae_N == 0.0
    assert out.final_position_error_m == 0.0


def test_each_failed_criterion_is_named_with_its_numbers():
    rec = clean_record()
    held = (rec["t_s"] > 0.25) & (rec["t_s"] < 0.3)
    rec["measured_force_N"][held] = 0.0
    out = run(measured_force_N=rec["measured_force_N"])
    assert out.dropped and any("no finger contact at t = 0.2" in r for r in out.reasons)

    slip = np.where(rec["t_s"] > 0.2, 3e-3, 0.0)
    out = run(slip_m=slip)
    assert any("slip 3.000 mm > limit 2.000 mm" in r for r in out.reasons)

    ext = np.zeros((40, 3))
    ext[rec["t_s"] > 0.35, 2] = 25.0
    out = run(external_force_N=ext)
    assert any("peak insertion force 25.00 N > limit 20.00 N" in r for r in out.reasons)

    T = rec["T_world_part"].copy()
    T[-1, 0, 3] = 2e-3
    out = run(T_world_part=T)
    assert any("final position error 2.000 mm > tolerance 1.000 mm" in r for r in out.reasons)

    out = run(max_penetration_m=np.full(40, 1e-3))
    assert any("penetration 1.000 mm > 0.500 mm" in r for r in out.reasons)


def test_energy_growth_is_flagged_when_the_part_outruns_the_motion():
    # trajectory peak speed 1 m/s: allowed v = 2 + 0.1 m/s -> KE limit 2 * 0.5 * 0.1 * 2.1^2
    ke = np.zeros(40)
    ke[-1] = 0.5
    out = run(kinetic_energy_J=ke)
    assert out.energy_growth and any("energy growth" in r for r in out.reasons)
    ke[-1] = 0.4
    assert not run(kinetic_energy_J=ke).energy_growth


def test_record_json_round_trip_keeps_nan_and_values():
    rec = StepRecord(**clean_record())
    back = StepRecord.from_dict(json.loads(json.dumps(rec.to_dict())))
    for name, a in rec.arrays().items():
        assert np.array_equal(a, back.arrays()[name], equal_nan=True), name
    assert back.phase_names == rec.phase_names
    out = run()
    json.dumps(out.to_dict())  # JSON-safe (NaN becomes None)


def test_criteria_and_record_validation():
    with pytest.raises(ValueError, match=r"max_slip_m: expected > 0, found -1"):
        SuccessCriteria(max_slip_m=-1.0)
    rec = clean_record()
    rec["slip_m"] = np.zeros(3)
    with pytest.raises(ValueError, match=r"slip_m: expected 40 rows"):
        StepRecord(**rec)


def test_scene_warnings_flag_what_a_preset_cannot_resolve():
    w = scene_warnings(0.05e-3, diametral_clearances_m=(0.02e-3, 0.1e-3), masses_kg=(1.0, 0.005))
    assert len(w) == 2
    assert "0.020 mm is below" in w[0] and "mass ratio 200:1" in w[1]
    tunnelling = scene_warnings(0.05e-3, smallest_feature_m=0.002, dt_s=1 / 240, peak_speed_mps=0.5)
    assert "tunnelling" in tunnelling[0]
    assert scene_warnings(0.05e-3, diametral_clearances_m=(0.1e-3,), masses_kg=(0.1, 0.05)) == ()
