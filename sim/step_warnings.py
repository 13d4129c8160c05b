"""Warnings of a step's simulation: fits, masses and speeds the fidelity preset cannot resolve.

:func:`clearance_warnings` names every mate whose smallest clearance is below what the preset
resolves and how a result is then to be read; :func:`step_warnings` adds the scene's masses,
sizes and speeds (:func:`asmplan.sim.execute.scene_warnings`); :func:`insertion_speed_warnings`
flags an insertion that advances more per time step than the preset's contact distance.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..knowledge.model import Product
from ..planner.plan import Step
from .execute import scene_warnings
from .fidelity import PRESETS, Fidelity
from .scene import StepScene

if TYPE_CHECKING:
    from ..parts.models import ProductGeometry


def clearance_warnings(product: Product, fidelity: Fidelity) -> tuple[str, ...]:
    """One warning per mate whose smallest declared clearance the preset cannot resolve,
    saying how a result is then to be read."""
    res = fidelity.min_resolvable_clearance_m
    better = sorted((f for f in PRESETS.values()), key=lambda f: -f.min_resolvable_clearance_m)
    out = []
    for m in product.mates:
        c = m.clearance_min_m
        if c >= res:
            continue
        fit = f", {m.fit}" if m.fit else ""
        head = (f"mate {m.name} ({m.pin_part}.{m.pin_feature} in {m.hole_part}.{m.hole_feature}"
                f"{fit}): ")
        if c < 0:
            out.append(
                head + f"a {m.kind} fit (interference up to {-c * 1e3:.3f} mm) cannot be "
                "modelled by rigid bodies: it is simulated at a clearance the "
                f"{fidelity.name} preset resolves (at most "
                f"{fidelity.interference_resolution_m * 1e3:.3f} mm) with its "
                "predicted press force as an axial resistance (asmplan.sim.press): a success "
                "shows the force and the guidance, not the fit's elastic contact.")
            continue
        finer = [f for f in better if f.min_resolvable_clearance_m <= c]
        advice = (f"Run --fidelity {finer[0].name} to resolve it" if finer else
                  f"No preset resolves it (finest: {better[-1].name}, "
                  f"{better[-1].min_resolvable_clearance_m * 1e3:.3f} mm)")
        out.append(
            head + f"smallest diametral clearance {c * 1e3:.3f} mm is below what the "
            f"{fidelity.name} preset resolves ({res * 1e3:.3f} mm; sim/fidelity.py): its "
            f"capture boundary (lateral offset < c/2 + chamfers), rim stops and jams are not "
            f"resolved there. A success means the pin went in at this preset's resolution, "
            f"not that the {c * 1e3:.3f} mm fit is proven; a failure of the insertion may be "
            f"numerical. {advice}.")
    return tuple(out)


def step_warnings(scene: StepScene, product: Product, step: Step, geometry: ProductGeometry,
                  fidelity: Fidelity) -> tuple[str, ...]:
    """:func:`asmplan.sim.execute.scene_warnings` for the fits, masses and speed of a step."""
    in_scene = set(scene.parts)
    dynamic = {b.name for b in scene.bodies if b.dynamic}
    clearances = [m.clearance_min_m for m in product.mates
                  if {m.pin_part, m.hole_part} <= in_scene
                  and (m.pin_part in dynamic or m.hole_part in dynamic)]
    masses = [b.mass_kg for b in scene.bodies if b.dynamic]
    assert step.trajectory is not None
    p = step.trajectory.T_world_gripper[:, :3, 3]
    dt = np.diff(step.trajectory.t_s)
    speed = float(np.max(np.linalg.norm(np.diff(p, axis=0), axis=1) / dt)) if dt.size else 0.0
    extents = np.asarray(geometry.mesh(step.part).extents, float)
    out = scene_warnings(fidelity.min_resolvable_clearance_m, clearances, masses,
                         float(extents.min()), fidelity.dt_s, speed)
    if step.kind == "insert":
        out = out + insertion_speed_warnings(product, step.part, fidelity)
    return out


def insertion_speed_warnings(product: Product, part: str, fidelity: Fidelity) -> tuple[str, ...]:
    """A warning when the part enters its fits faster than the preset finds a contact before
    penetrating: ``insertion speed x dt_s`` above ``Fidelity.contact_distance_m`` (the rim of
    an unchamfered hole may then be stepped over, sim/fidelity.py)."""
    from ..planner.timing import motion_limits

    v = motion_limits(product, part).insertion_speed_m_s
    advance = v * fidelity.dt_s
    if advance <= fidelity.contact_distance_m:
        return ()
    return (f"{part} is inserted at {v * 1e3:.1f} mm/s, {advance * 1e6:.1f} um per "
            f"{fidelity.name} time step, more than the {fidelity.contact_distance_m * 1e6:.1f} um "
            "at which the preset finds a contact before penetrating: a rim stop or jam of its "
            "fits may be stepped over; lower process.insertion_speed or use a finer preset",)
