"""Fits a fidelity preset cannot resolve, per mate: one table row each in the report and one
grouped warning in the terminal (instead of one long paragraph per mate)."""

from __future__ import annotations

from typing import Any

from ..knowledge.model import Product
from ..sim.fidelity import PRESETS


def unresolved_fits(product: Product, fidelity: Any) -> list[dict[str, Any]]:
    """Mates whose smallest diametral clearance the preset cannot resolve, one row each
    (the per-mate form of :func:`asmplan.sim.step_warnings.clearance_warnings`)."""
    if fidelity is None:
        return []
    res = fidelity.min_resolvable_clearance_m
    finest = min(PRESETS.values(), key=lambda f: f.min_resolvable_clearance_m)
    rows = []
    for m in product.mates:
        c = m.clearance_min_m
        if c >= res:
            continue
        finer = sorted((f for f in PRESETS.values() if f.min_resolvable_clearance_m <= c),
                       key=lambda f: -f.min_resolvable_clearance_m)
        rows.append({"mate": m.name, "pin": f"{m.pin_part}.{m.pin_feature}",
                     "hole": f"{m.hole_part}.{m.hole_feature}", "fit": m.fit or "explicit",
                     "kind": m.kind, "clearance_um": c * 1e6, "resolution_um": res * 1e6,
                     "advice": ("interference: rigid bodies cannot model it" if c < 0 else
                                f"run --fidelity {finer[0].name}" if finer else
                                f"no preset resolves it (finest {finest.name}: "
                                f"{finest.min_resolvable_clearance_m * 1e6:.0f} µm)")})
    return rows


def grouped_fit_warning(rows: list[dict[str, Any]], fidelity_name: str,
                        mate_steps: dict[str, int] | None = None) -> str:
    """One warning for every unresolved fit (rows of :func:`unresolved_fits`), mates with the
    same fit, clearance and step listed together, each named; "" when there is none."""
    if not rows:
        return ""
    mate_steps = mate_steps or {}
    groups: dict[tuple[str, int, str], list[str]] = {}
    for r in rows:
        k = mate_steps.get(r["mate"])
        where = f", step {k + 1}" if k is not None and k >= 0 else ""
        groups.setdefault((r["fit"], round(r["clearance_um"]), where), []).append(r["mate"])
    listed = "; ".join(f"{', '.join(m)} ({fit}, {c} µm{where})"
                       for (fit, c, where), m in groups.items())
    res = rows[0]["resolution_um"]
    advice = sorted({r["advice"] for r in rows})
    return (f"{len(rows)} mate{'s' if len(rows) > 1 else ''} with a smallest diametral clearance "
            f"below what the {fidelity_name} preset resolves ({res:.0f} µm): {listed}. A success "
            f"there means the pin went in at this resolution (the capture boundary, rim stops "
            f"and jams of a finer fit are not resolved), not that the fit is proven; a failed insertion "
            f"there may be numerical. {'; '.join(a[0].upper() + a[1:] for a in advice)}.")
