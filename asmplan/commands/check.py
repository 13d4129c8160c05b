"""``asmplan check PRODUCT``: build the geometry, check every mate's clearance and every
interference at the assembled poses.

Exit codes: 0 the assembly checks clean, 1 a check failed (interference, a clearance outside
its declared range, a feature error), 2 bad input (including unusable mesh files).
"""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING

import numpy as np

from ..parts.lod import LEVELS

if TYPE_CHECKING:  # geometry and FCL are imported when the check runs
    from ..parts.check import AssemblyCheck


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("check", help="check clearances and interferences of the assembled product",
                       description="Place every part at its assembled pose and report, per mate, the "
                                   "clearance measured with FCL against the declared fit, and every "
                                   "interference between parts (pair and depth). Exit code 1 when "
                                   "the assembly interferes or a check fails, 2 on bad input.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--level", choices=LEVELS, default="exact",
                   help="collision model level of detail (default: exact)")
    p.add_argument("--tolerance-um", type=float, default=1.0,
                   help="contacts up to this depth count as touching (default 1 um)")
    p.set_defaults(func=run)


def _um(v: float) -> str:
    return f"{v * 1e6:+8.2f}"


def _force(v: float) -> str:
    return f"{v / 1e3:.3g} kN" if v >= 1e3 else f"{v:.3g} N"


def render(result: AssemblyCheck) -> str:
    """The check as a text table."""
    lines = [f'product "{result.product}": level {result.level}, '
             f"{'OK' if result.success else 'FAILED'}"]
    if result.mates:
        w = max(len(m.mate) for m in result.mates)
        lines.append(f"  {'mate':<{w}}  {'fit':<6} {'declared um':>19}  {'built um':>8}  {'measured um':>11}"
                     f"  {'bound um':>8}  ok")
        for m in result.mates:
            declared = f"{_um(m.declared_min_m)}..{_um(m.declared_max_m).strip()}"
            lines.append(f"  {m.mate:<{w}}  {m.fit or '-':<6} {declared:>19}  {_um(m.built_m)}  "
                         f"{_um(m.measured_m):>11}  {m.bound_m * 1e6:8.3f}  "
                         f"{'yes' if m.measured_within else 'NO'}")
    if result.press_fits:
        w = max(len(p.mate) for p in result.press_fits)
        lines.append(f"  {'press fit':<{w}}  {'fit':<6} {'P(interf.)':>10}  "
                     f"{'press force N (min/typ/max)':>30}  {'d mm':>6} {'L mm':>6} {'D_o mm':>7} "
                     f"{'d_i mm':>6}  mu    materials")
        for pf in result.press_fits:
            lo, typ, hi = pf.force_N
            D_o = ("inf" if not np.isfinite(pf.hub_outer_diameter_m)
                   else f"{pf.hub_outer_diameter_m * 1e3:.1f}")
            lines.append(f"  {pf.mate:<{w}}  {pf.fit or '-':<6} {pf.probability_interference:>10.1%}  "
                         f"{_force(lo):>9} / {_force(typ):>8} / {_force(hi):>8}  "
                         f"{pf.diameter_m * 1e3:6.2f} {pf.engaged_length_m * 1e3:6.2f} {D_o:>7} "
                         f"{pf.male_bore_diameter_m * 1e3:6.2f}  {pf.mu:.2f}  "
                         f"{pf.male_material} in {pf.hub_material}")
    if result.interferences:
        for i in result.interferences:
            p = ", ".join(f"{v * 1e3:.2f}" for v in i.point_m)
            axis = "xyz"[int(np.argmax(np.abs(i.separate_along)))]
            sign = "+" if max(i.separate_along, key=abs) > 0 else "-"
            lines.append(f"  INTERFERENCE {i.a} / {i.b}: depth {i.depth_m * 1e3:.4g} mm (moving {i.a} by "
                         f"that along {sign}{axis} clears it), contact at ({p}) mm")
    else:
        lines.append("  no interference between parts")
    for i in result.intended_contacts:
        lines.append(f"  intended overlap {i.a} / {i.b}: {i.depth_m * 1e6:.2f} um (mate {i.intended_by})")
    for f in result.findings:
        lines.append(f"  {f.severity}: {f.subject}: {f.message}")
    t = result.timings_s
    ms = {k: 1e3 * t.get(k, 0.0) for k in ("world_s", "mates_s", "contacts_s")}
    lines.append(f"  timing: geometry {t.get('geometry_s', 0):.3f} s, world {ms['world_s']:.1f} ms, "
                 f"mates {ms['mates_s']:.1f} ms, contacts {ms['contacts_s']:.1f} ms, "
                 f"features {t.get('features_s', 0):.3f} s")
    if not result.success:
        lines.append(f"  reason: {result.reason}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from ..knowledge.loader import load_product
    from ..parts.check import check_assembly
    from ..parts.models import ProductGeometry

    product = load_product(args.product)
    geometry = ProductGeometry(product)
    result = check_assembly(product, geometry, level=args.level, tolerance_m=args.tolerance_um * 1e-6)
    if args.json:
        print(json.dumps(result.as_dict(), indent=2))
    else:
        print(render(result))
    return 0 if result.success else 1
