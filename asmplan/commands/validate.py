"""``asmplan validate PRODUCT``: check a product file and summarise it."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..knowledge.loader import load_product
from ..knowledge.model import Product


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="check a product file and print a summary",
                       description="Validate a product YAML file. Every problem is reported "
                                   "at once with file:line:column, key path, expected and found; "
                                   "exit code 2 when there is any.")
    p.add_argument("product", help="product YAML file")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=run)


def summary(product: Product) -> dict[str, Any]:
    """A JSON-safe summary of a validated product (SI units)."""
    return {
        "product": product.name,
        "source": str(product.source),
        "parts": [{"name": p.name, "geometry": p.geometry.kind,
                   "material": p.material.name if p.material else None,
                   "mass_kg": p.mass_kg, "fixtured": product.is_fixtured(p.name),
                   "placed_by": p.handling.operation,
                   "features": [f.name for f in p.features], "start": p.start_location}
                  for p in product.parts],
        "mates": [{"name": m.name, "pin": f"{m.pin_part}.{m.pin_feature}",
                   "hole": f"{m.hole_part}.{m.hole_feature}", "fit": m.fit, "kind": m.kind,
                   "clearance_min_m": m.clearance_min_m, "clearance_max_m": m.clearance_max_m,
                   **({"fit_source": m.fit_source} if m.fit_source else {})}
                  for m in product.mates],
        "base": product.precedence.base,
        "rules": [{"before": r.before, "after": r.after, "reason": r.reason}
                  for r in product.precedence.rules],
        "groups": [{"parts": list(g.parts), "reason": g.reason} for g in product.precedence.groups],
        "fixtures": [{"name": f.name, "holds": f.holds} for f in product.resources.fixtures],
    }


def run(args: argparse.Namespace) -> int:
    from ..knowledge.errors import ProductError
    from ..parts.input_warnings import body_issues, geometry_warnings

    product = load_product(args.product)
    issues = body_issues(product)
    if issues:
        raise ProductError(issues)
    info = summary(product)
    warnings = geometry_warnings(product)
    if args.json:
        print(json.dumps({"valid": True, **info, "warnings": warnings}, indent=2))
        return 0
    for w in warnings:
        print(f"{args.product}: warning: {w}", file=sys.stderr)
    print(f'{args.product}: valid product "{product.name}": {len(product.parts)} parts, '
          f"{len(product.mates)} mates, {len(product.precedence.rules)} rules")
    width = max(len(p.name) for p in product.parts)
    for p in info["parts"]:
        extra = " (fixtured)" if p["fixtured"] else f" from {p['start']}"
        if p["placed_by"]:
            extra += f" (placed by {p['placed_by']}: not a gripper step)"
        print(f"  part  {p['name']:<{width}}  {p['geometry']:<9} {p['material'] or 'given mass':<10}"
              f"{extra}")
    for m in info["mates"]:
        lo, hi = m["clearance_min_m"] * 1e6, m["clearance_max_m"] * 1e6
        print(f"  mate  {m['name']}: {m['pin']} in {m['hole']}  {m['fit'] or 'explicit'} "
              f"{m['kind']} {lo:+.0f}..{hi:+.0f} um")
        if m.get("fit_source"):
            print(f"        default fit (line to line): {m['fit_source']}")
    if product.precedence.base:
        print(f"  base  {product.precedence.base}")
    for r in info["rules"]:
        print(f"  rule  {r['before']} before {r['after']}: {r['reason']}")
    return 0
