"""The validation scenes in a peer engine, MuJoCo, side by side with PyBullet (issue 16).

Optional (``pip install asmplan[peers]``); the only module importing ``mujoco``. MuJoCo runs
at its recommended stiff-contact settings, not tuned down: elliptic friction cones,
``impratio`` 10, ``solref`` time constant 2 dt with damping ratio 1, ``noslip_iterations`` 20.
Every cost is CPU seconds (``time.process_time``) per simulated second: the machines the bench
runs on are shared, and CPU time is what a run costs whatever else runs beside it.

* :func:`mujoco_jam_depth_m`: Whitney's two-point jam depth of the 10 mm steel peg of
  :class:`bench.scenarios.JamScene`, held at a fixed tilt (two slide joints: it
  translates, it cannot turn), pushed down 2 N and sideways 0.5 N at most 5 mm/s into a
  16-sided blind hole (faces at +-x) of inscribed diameter D = d + c, friction 0.3.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np


def available() -> bool:
    """Whether MuJoCo is installed (the ``peers`` extra)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def _hole_xml(D: float, depth: float, top: float, sides: int = 16, wall: float = 0.01) -> str:
    """Box geoms forming a ``sides``-gon blind hole of inscribed diameter D, faces at +-x."""
    out = []
    r = D / 2.0
    half_len = (r + wall) * math.tan(math.pi / sides) + 1e-5
    zc = top - depth / 2.0
    for k in range(sides):
        phi = 2.0 * math.pi * k / sides
        cx, cy = (r + wall / 2.0) * math.cos(phi), (r + wall / 2.0) * math.sin(phi)
        out.append(f'<geom type="box" size="{wall / 2} {half_len} {depth / 2}" '
                   f'pos="{cx} {cy} {zc}" euler="0 0 {math.degrees(phi)}"/>')
    out.append(f'<geom type="box" size="{r + wall} {r + wall} 0.005" '
               f'pos="0 0 {top - depth - 0.005}"/>')
    return "\n    ".join(out)


def mujoco_jam_depth_m(dt_s: float, clearance_m: float, tilt_rad: float,
                       peg_diameter_m: float = 0.010, push_N: float = 2.0, side_N: float = 0.5,
                       max_speed_mps: float = 0.005, settle_s: float = 1.0,
                       friction: float = 0.3, ccd_tolerance: float | None = None
                       ) -> tuple[float, float]:
    """(jam depth, m, as :func:`bench.scenarios.whitney_jam_depth_m` defines it; CPU
    seconds per simulated second) of the MuJoCo scene at time step ``dt_s``.

    ``ccd_tolerance``: MuJoCo's convex collision tolerance (its ``option/ccd_tolerance``,
    default 1e-6), used by its cylinder-box contact. At 1e-6 the converged jam at 0.5 deg
    stays ~0.09 mm deep (1/sin t x a ~1 um contact error) at every step from 0.1 to 0.02 ms;
    at 1e-10 it converges with the step (measured; no change in cost at 0.1 ms)."""

    d, L, depth, top = peg_diameter_m, 0.030, 0.020, 0.030
    D = d + clearance_m
    c, sn = math.cos(tilt_rad), math.sin(tilt_rad)
    e = np.array([c, 0.0, sn])
    u = np.array([-sn, 0.0, c])
    corner = np.array([D / 2.0 - 2e-6, 0.0, top - 0.05e-3])
    centre = corner - (d / 2.0) * e + (L / 2.0) * u
    mass = 7800.0 * math.pi * (d / 2.0) ** 2 * L
    ccd = "" if ccd_tolerance is None else f' ccd_tolerance="{ccd_tolerance:g}"'
    xml = f"""
<mujoco>
  <compiler angle="degree"/>
  <option timestep="{dt_s}" cone="elliptic" impratio="10" noslip_iterations="20"
          gravity="0 0 -9.81"{ccd}/>
  <default><geom solref="{2 * dt_s} 1" solimp="0.95 0.99 0.001" condim="3"
                 friction="{friction} 0.005 0.0001"/></default>
  <worldbody>
    {_hole_xml(D, depth, top)}
    <body name="peg" pos="{centre[0]} 0 {centre[2]}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom type="cylinder" size="{d / 2} {L / 2}" euler="0 {-math.degrees(tilt_rad)} 0"
            mass="{mass}"/>
    </body>
  </worldbody>
</mujoco>"""
    data, cpu_per_s = _pushed(xml, (side_N, -push_N), settle_s, dt_s, max_speed_mps)
    pos = centre + np.array([data.qpos[0], 0.0, data.qpos[1]])
    trailing = pos - (L / 2.0) * u - (d / 2.0) * e
    return float((top - trailing[2]) / u[2]), cpu_per_s


def _pushed(xml: str, force: tuple[float, ...], settle_s: float, dt_s: float,
            max_speed_mps: float) -> tuple[Any, float]:
    """Run the model of ``xml`` for ``settle_s`` with ``force`` on its slide joints (one each,
    in order), the body's speed capped at ``max_speed_mps`` (a robot feeding slowly near
    contact). Returns (the final ``MjData``, CPU seconds per simulated second)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    k = len(force)
    n = round(settle_s / dt_s)
    t0 = time.process_time()
    for _ in range(n):
        data.qfrc_applied[:] = force
        mujoco.mj_step(model, data)
        v = data.qvel[:k].copy()
        speed = float(np.linalg.norm(v))
        if speed > max_speed_mps:
            data.qvel[:k] = v * (max_speed_mps / speed)
    return data, (time.process_time() - t0) / settle_s


# --------------------------------------------------------------------------------------------
# Held parts: slip threshold and drift (a parallel gripper on a kinematic palm)
# --------------------------------------------------------------------------------------------
def _header(dt_s: float, friction: float) -> str:
    """MuJoCo's recommended stiff-contact settings (module docstring)."""
    return f"""
  <compiler angle="degree"/>
  <option timestep="{dt_s}" cone="elliptic" impratio="10" noslip_iterations="20"
          gravity="0 0 -9.81"/>
  <default><geom solref="{2 * dt_s} 1" solimp="0.95 0.99 0.001" condim="3"
                 friction="{friction} 0.005 0.0001"/></default>"""


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return q


def mujoco_gripper_run(dt_s: float, t_s: np.ndarray, T_world_palm: np.ndarray,
                       clamp_force_N: np.ndarray, part_size_m: tuple[float, float, float],
                       part_mass_kg: float, T_world_part0: np.ndarray, friction: float,
                       opening_m: float, ground: bool, pad_size_m: tuple[float, float, float]
                       = (0.02, 0.006, 0.02), finger_mass_kg: float = 0.02,
                       finger_damping_Nspm: float = 2.0) -> tuple[np.ndarray, np.ndarray, float]:
    """A box part held by a synchronised parallel gripper in MuJoCo.

    The palm (0.3 kg) is welded, at MuJoCo's stiffest reference (time constant 2 dt), to a
    mocap target following ``T_world_palm`` (n, 4, 4) at ``t_s`` (linear interpolation
    between samples; TCP frame as in asmplan: fingers close along its y axis; a mocap body
    itself has no velocity in the dynamics, so pads on it would not drag the part);
    two pad bodies on slide joints, coupled by a joint equality (as a synchronised gripper),
    each pushed toward the centre by a motor with ``clamp_force_N`` (so the squeeze is the
    commanded force), joint damping ``finger_damping_Nspm``. Friction is MuJoCo's (the
    larger of the two geoms'): every geom gets ``friction``.

    Returns (t (m,), T_palm_part (m, 4, 4) at every step, CPU seconds per simulated second).
    """
    import mujoco

    hx, hy, hz = (0.5 * v for v in part_size_m)
    px, py, pz = (0.5 * v for v in pad_size_m)
    y0 = 0.5 * opening_m + py
    P0 = T_world_part0
    q_part = _quat_wxyz(P0[:3, :3])
    q_palm = _quat_wxyz(T_world_palm[0][:3, :3])
    floor = '<geom type="plane" size="1 1 0.01"/>' if ground else ""
    xml = f"""<mujoco>{_header(dt_s, friction)}
  <worldbody>
    {floor}
    <body name="part" pos="{P0[0, 3]} {P0[1, 3]} {P0[2, 3]}"
          quat="{q_part[0]} {q_part[1]} {q_part[2]} {q_part[3]}">
      <freejoint/>
      <geom type="box" size="{hx} {hy} {hz}" mass="{part_mass_kg}"/>
    </body>
    <body name="target" mocap="true" pos="{T_world_palm[0][0, 3]} {T_world_palm[0][1, 3]}
          {T_world_palm[0][2, 3]}" quat="{q_palm[0]} {q_palm[1]} {q_palm[2]} {q_palm[3]}"/>
    <body name="palm" pos="{T_world_palm[0][0, 3]} {T_world_palm[0][1, 3]}
          {T_world_palm[0][2, 3]}" quat="{q_palm[0]} {q_palm[1]} {q_palm[2]} {q_palm[3]}">
      <freejoint/>
      <inertial pos="0 0 0" mass="0.3" diaginertia="1e-3 1e-3 1e-3"/>
      <body name="f1" pos="0 {y0} 0">
        <joint name="j1" type="slide" axis="0 -1 0" damping="{finger_damping_Nspm}"/>
        <geom type="box" size="{px} {py} {pz}" mass="{finger_mass_kg}"/>
      </body>
      <body name="f2" pos="0 {-y0} 0">
        <joint name="j2" type="slide" axis="0 1 0" damping="{finger_damping_Nspm}"/>
        <geom type="box" size="{px} {py} {pz}" mass="{finger_mass_kg}"/>
      </body>
    </body>
  </worldbody>
  <equality><joint joint1="j1" joint2="j2"/>
    <weld body1="palm" body2="target" solref="{2 * dt_s} 1"/></equality>
  <actuator><motor joint="j1"/><motor joint="j2"/></actuator>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    part = model.body("part").id
    palm = model.body("palm").id
    n = round((float(t_s[-1]) - float(t_s[0])) / dt_s)
    ts = float(t_s[0]) + dt_s * np.arange(1, n + 1)
    pos = np.column_stack([np.interp(ts, t_s, T_world_palm[:, k, 3]) for k in range(3)])
    force = np.interp(ts, t_s, clamp_force_N)
    idx = np.clip(np.searchsorted(t_s, ts), 0, len(t_s) - 1)
    quats = np.array([_quat_wxyz(T_world_palm[k][:3, :3]) for k in np.unique(idx)])
    qmap = dict(zip(np.unique(idx).tolist(), quats, strict=True))
    out = np.zeros((n, 4, 4))
    t0 = time.process_time()
    for i in range(n):
        data.mocap_pos[0] = pos[i]
        data.mocap_quat[0] = qmap[int(idx[i])]
        data.ctrl[:] = force[i]
        mujoco.mj_step(model, data)
        Tw = np.eye(4)
        Tw[:3, :3] = data.xmat[part].reshape(3, 3)
        Tw[:3, 3] = data.xpos[part]
        Tp = np.eye(4)
        Tp[:3, :3] = data.xmat[palm].reshape(3, 3)
        Tp[:3, 3] = data.xpos[palm]
        out[i] = np.linalg.inv(Tp) @ Tw
    cpu = time.process_time() - t0
    return ts, out, cpu / (n * dt_s)


# --------------------------------------------------------------------------------------------
# Capture boundary: an unchamfered pin lowered off-axis onto a hole
# --------------------------------------------------------------------------------------------
def mujoco_capture_entered_m(dt_s: float, radial_clearance_m: float, offset_m: float,
                             hole_radius_m: float = 0.005, hole_depth_m: float = 0.020,
                             sides: int = 8, push_N: float = 5.0, max_speed_mps: float = 0.02,
                             settle_s: float = 1.0, friction: float = 0.5
                             ) -> tuple[float, float]:
    """(depth entered, m; CPU seconds per simulated second): a steel pin of radius
    ``hole_radius_m - radial_clearance_m``, 40 mm long, held upright by a stiff robot (three
    slide joints: it translates, it cannot turn), ``offset_m`` off the hole's axis toward a
    flat face, its bottom 0.5 mm above the mouth, pushed down with ``push_N`` at most
    ``max_speed_mps`` fast into an unchamfered ``sides``-gon blind hole (inscribed radius
    ``hole_radius_m``). Analytic: it is captured only if ``|offset| < radial clearance``."""

    r = hole_radius_m - radial_clearance_m
    L, top = 0.040, 0.030
    mass = 7800.0 * math.pi * r * r * L
    z0 = top + 0.5e-3 + L / 2.0
    xml = f"""<mujoco>{_header(dt_s, friction)}
  <worldbody>
    {_hole_xml(2.0 * hole_radius_m, hole_depth_m, top, sides)}
    <body name="pin" pos="{offset_m} 0 {z0}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom type="cylinder" size="{r} {L / 2}" mass="{mass}"/>
    </body>
  </worldbody>
</mujoco>"""
    data, cpu_per_s = _pushed(xml, (0.0, 0.0, -push_N), settle_s, dt_s, max_speed_mps)
    bottom = z0 + float(data.qpos[2]) - L / 2.0
    return top - bottom, cpu_per_s


# --------------------------------------------------------------------------------------------
# Mass ratio: a 100 kg block on four 1 g cubes
# --------------------------------------------------------------------------------------------
def mujoco_heavy_on_light(dt_s: float, settle_s: float = 1.0, friction: float = 0.5
                          ) -> tuple[float, float, float]:
    """(largest cube speed, m/s; block's sink, m; CPU seconds per simulated second): a
    120 x 120 x 900 mm, 100 kg block resting on four 10 mm, 1 g cubes on the ground (as
    ``tests/sim/test_guards.py``). Analytic: nothing moves."""
    import mujoco

    cubes = "\n    ".join(
        f'<body pos="{dx} {dy} 0.005"><freejoint/><geom type="box" size="0.005 0.005 0.005" '
        f'mass="0.001"/></body>' for dx in (-0.04, 0.04) for dy in (-0.04, 0.04))
    xml = f"""<mujoco>{_header(dt_s, friction)}
  <worldbody>
    <geom type="plane" size="1 1 0.01"/>
    {cubes}
    <body name="block" pos="0 0 0.46"><freejoint/>
      <geom type="box" size="0.06 0.06 0.45" mass="100"/></body>
  </worldbody>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    n = round(settle_s / dt_s)
    block = model.body("block").id
    z0 = 0.46
    vmax = 0.0
    t0 = time.process_time()
    for _ in range(n):
        mujoco.mj_step(model, data)
        for k in range(4):
            vmax = max(vmax, float(np.linalg.norm(data.qvel[6 * k: 6 * k + 3])))
    cpu = time.process_time() - t0
    return vmax, z0 - float(data.xpos[block][2]), cpu / settle_s
