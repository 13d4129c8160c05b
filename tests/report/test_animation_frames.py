"""Which ticks of a simulated step the report's animation shows (report/views.animation_ticks):
the start of every phase in which something moves, the middle of long phases and the end;
never two frames that show the same picture."""

from __future__ import annotations

import itertools

import numpy as np

from asmplan.report.views import ANIMATION_STILL_M, animation_ticks
from asmplan.sim.records import StepRecord

# phase: (duration s, gripper z at its end m, open?)  the gripper starts at z = 0.05
PHASES = (("approach", 0.3, 0.0, True), ("clamp", 0.3, 0.0, False), ("hold", 0.2, 0.0, False),
          ("lift", 0.3, 0.05, False), ("translate", 1.5, 0.05, False),
          ("lower", 1.9, 0.0, False), ("release", 0.3, 0.0, True), ("retreat", 0.5, 0.05, True))
DT = 0.01


def _record() -> tuple[StepRecord, list[int]]:
    t, z, x, idx = [], [], [], []
    t0, z0, x0 = 0.0, 0.05, 0.0
    for k, (_, dur, z1, _) in enumerate(PHASES):
        n = round(dur / DT)
        s = np.arange(n) / n
        x1 = x0 + (0.1 if PHASES[k][0] == "translate" else 0.0)
        t += list(t0 + s * dur)
        z += list(z0 + s * (z1 - z0))
        x += list(x0 + s * (x1 - x0))
        idx += [k] * n
        t0, z0, x0 = t0 + dur, z1, x1
    n = len(t)
    T = np.repeat(np.eye(4)[None], n, axis=0)
    T[:, 0, 3], T[:, 2, 3] = x, z
    held = np.isin(idx, [1, 2, 3, 4, 5])
    part = T.copy()
    part[~held & (np.array(idx) < 1), :3, 3] = [0.0, 0.0, 0.0]  # on the tray before the clamp
    part[np.array(idx) > 5, :3, 3] = T[np.flatnonzero(np.array(idx) == 5)[-1], :3, 3]
    rec = StepRecord(
        phase_names=tuple(p[0] for p in PHASES), t_s=np.array(t), phase_index=np.array(idx),
        commanded_force_N=np.zeros(n), measured_force_N=np.zeros((n, 2)), slip_m=np.zeros(n),
        slip_rad=np.zeros(n), T_world_part=part, T_world_gripper=T,
        finger_travel_m=np.zeros((n, 2)), axial_error_m=np.full(n, np.nan),
        lateral_error_m=np.full(n, np.nan), external_force_N=np.zeros((n, 3)),
        max_penetration_m=np.zeros(n), speed_mps=np.zeros(n), kinetic_energy_J=np.zeros(n))
    return rec, [k for k, p in enumerate(PHASES) if p[3]]


def test_every_moving_phase_starts_a_frame_and_still_ones_are_left_out() -> None:
    rec, open_phases = _record()
    ticks = animation_ticks(rec, open_phases)
    shown = [rec.phase_names[rec.phase_index[k]] for k in ticks]
    starts = {name: int(np.flatnonzero(rec.phase_index == i)[0])
              for i, name in enumerate(rec.phase_names)}
    # the start of each phase whose first picture differs from the frame before it
    for name in ("approach", "clamp", "translate", "lower", "release"):
        assert starts[name] in ticks, (name, shown)
    # "hold" and "lift" start where "clamp" began (the lift's motion shows in the next frame),
    # "retreat" where "release" began (open at the same place): the same picture, left out
    for name in ("hold", "lift", "retreat"):
        assert starts[name] not in ticks, (name, shown)
    # the long phases (more than a fifth of the step) also in their middle; the end of the step
    assert shown.count("translate") == 2 and shown.count("lower") == 2
    assert ticks[-1] == rec.n_ticks - 1 and ticks[0] == 0
    # no two consecutive frames show the same picture
    part, grip = rec.T_world_part[:, :3, 3], rec.T_world_gripper[:, :3, 3]
    opened = np.isin(rec.phase_index, open_phases)
    for a, b in itertools.pairwise(ticks):
        moved = max(np.linalg.norm(part[b] - part[a]), np.linalg.norm(grip[b] - grip[a]))
        assert moved > ANIMATION_STILL_M or opened[a] != opened[b], (a, b)
    assert len(ticks) < 12  # fewer frames than the 12 evenly spaced ones before


def test_more_candidates_than_frames_are_thinned_evenly() -> None:
    rec, open_phases = _record()
    ticks = animation_ticks(rec, open_phases, frames=4)
    assert len(ticks) == 4 and ticks[0] == 0 and ticks[-1] == rec.n_ticks - 1
    assert np.all(np.diff(ticks) > 0)
