"""The validation scenes in a peer engine, MuJoCo, side by side with PyBullet (issue 16).

Optional (``pip install asmplan[peers]``); the only module importing ``mujoco``. MuJoCo runs
at its recommended stiff-contact settings, not tuned down: elliptic friction cones,
``impratio`` 10, ``solref`` time constant 2 dt with damping ratio 1, ``noslip_iterations`` 20.

* :func:`mujoco_jam_depth_m`: Whitney's two-point jam depth of the 10 mm steel peg of
  :class:`bench.scenarios.JamScene`, held at a fixed tilt (two slide joints: it
  translates, it cannot turn), pushed down 2 N and sideways 0.5 N at most 5 mm/s into a
  16-sided blind hole (faces at +-x) of inscribed diameter D = d + c, friction 0.3.
"""

from __future__ import annotations

import math
import time

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
                       friction: float = 0.3) -> tuple[float, float]:
    """(jam depth, m, as :func:`bench.scenarios.whitney_jam_depth_m` defines it; wall
    seconds per simulated second) of the MuJoCo scene at time step ``dt_s``."""
    import mujoco

    d, L, depth, top = peg_diameter_m, 0.030, 0.020, 0.030
    D = d + clearance_m
    c, sn = math.cos(tilt_rad), math.sin(tilt_rad)
    e = np.array([c, 0.0, sn])
    u = np.array([-sn, 0.0, c])
    corner = np.array([D / 2.0 - 2e-6, 0.0, top - 0.05e-3])
    centre = corner - (d / 2.0) * e + (L / 2.0) * u
    mass = 7800.0 * math.pi * (d / 2.0) ** 2 * L
    xml = f"""
<mujoco>
  <compiler angle="degree"/>
  <option timestep="{dt_s}" cone="elliptic" impratio="10" noslip_iterations="20"
          gravity="0 0 -9.81"/>
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
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    n = round(settle_s / dt_s)
    t0 = time.perf_counter()
    for _ in range(n):
        data.qfrc_applied[:] = (side_N, -push_N)
        mujoco.mj_step(model, data)
        v = data.qvel[:2].copy()
        speed = float(np.linalg.norm(v))
        if speed > max_speed_mps:  # a robot feeding slowly near contact
            data.qvel[:2] = v * (max_speed_mps / speed)
    wall = time.perf_counter() - t0
    pos = centre + np.array([data.qpos[0], 0.0, data.qpos[1]])
    trailing = pos - (L / 2.0) * u - (d / 2.0) * e
    return float((top - trailing[2]) / u[2]), wall / settle_s
