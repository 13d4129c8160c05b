"""Seeded generator of realistic test products of any size (for tests and scaling benchmarks).

A generated product is a fixtured base plate carrying a grid of cells. Each cell holds a
stack of 1-3 blocks, each block pinned into the one below (two pins going down, -z; fit
H7/g6 unless ``fit`` says otherwise).
Some cells add a side plate pinned horizontally into the top block's +x or +y face (inserted
along -x or -y; the plate stands on the base, 0.2 mm above it when seated, so that a loose
pin does not leave it hanging), and some a cover on the top block: a flat cover pinned into it (-z) or,
when the cell has a side plate, an L-shaped cover that rests on the block with a flange
hanging in front of the side plate. The flange blocks the side plate's only way in, so "side
plate before cover" is a precedence that only the geometry reveals (like the cover of the
gear_unit example). Each box carries holes along one axis only (top face, or one side face).

Lengths in the returned document are millimetres (``units: {length: mm, mass: g}``); parts
start on trays in rows in front of the base (-y), ``TRAY_PITCH_MM`` apart, on a table sized to
hold them all. The first cell is always a 2-block stack
with a side plate and an L-cover (so 5 parts already show two insertion axes and a cover);
further cells are drawn from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .loader import build_product
from .model import Product
from .yamlsource import parse_located

PITCH_MM = 100.0
BASE_T_MM = 15.0
BLOCK_MM = (40.0, 40.0, 20.0)
PIN_D_MM, PIN_L_MM, PIN_X_MM = 6.0, 6.0, 12.0
SIDE_T_MM, SIDE_W_MM = 6.0, 60.0
SIDE_GAP_MM = 0.2
SIDE_PIN_D_MM = 5.0
COVER_T_MM = 5.0
FLANGE_T_MM, FLANGE_GAP_MM, FLANGE_DROP_MM = 5.0, 4.0, 19.0
TRAY_PITCH_MM = 100.0


def _cells(n_parts: int, rng: np.random.Generator) -> list[dict[str, Any]]:
    remaining = n_parts - 1
    cells: list[dict[str, Any]] = []
    while remaining > 0:
        if not cells:
            levels = min(2, remaining)
            side = "+x" if remaining > levels else None
            cover = remaining > levels + 1
        else:
            levels = min(int(rng.integers(1, 4)), remaining)
            left = remaining - levels
            side = str(rng.choice(["+x", "+y"])) if left > 0 and rng.random() < 0.5 else None
            left -= side is not None
            cover = bool(left > 0 and rng.random() < 0.4)
        cells.append({"levels": levels, "side": side, "cover": cover})
        remaining -= levels + (side is not None) + cover
    return cells


def _r(v: float) -> float:
    return round(float(v), 6)


# Complexity above C (radon): one linear recipe of a product document (base, parts, mates, rules);
# each branch is one option of the generated topology, kept in reading order.
def generate_product(n_parts: int, seed: int, *, fit: str | float = "H7/g6") -> dict[str, Any]:
    """A YAML-ready product document with exactly ``n_parts`` parts.

    Parameters
    ----------
    n_parts : int
        Number of parts, >= 2 (the base plate and at least one block).
    seed : int
        Seed of ``numpy.random.default_rng``; the same (n_parts, seed) gives the same document.
    fit : str or float
        Fit of every pin in its hole: an ISO 286 fit name (default "H7/g6", 4-24 um on the 6 mm
        pins), or a diametral clearance in millimetres (a mate ``clearance``). Simulation
        benchmarks pass a clearance the preset resolves
        (``Fidelity.min_resolvable_clearance_m``: 4 um at BALANCED, 2 mm at FAST), so that a
        failed step is physics, not the preset's resolution.

    Returns
    -------
    dict
        A product document (format version 1, millimetres and grams) that
        :func:`asmplan.knowledge.loader.build_product` accepts; see :func:`generated_product`.
    """
    if not isinstance(n_parts, int) or n_parts < 2:
        raise ValueError(f"n_parts: expected an integer >= 2, found {n_parts!r}")
    if isinstance(fit, str):
        fit_spec: dict[str, Any] = {"fit": fit}
    elif isinstance(fit, int | float) and not isinstance(fit, bool) and math.isfinite(fit) and fit >= 0:
        fit_spec = {"clearance": _r(fit)}
    else:
        raise ValueError(f"fit: expected an ISO fit name or a clearance >= 0 in mm, found {fit!r}")
    rng = np.random.default_rng(seed)
    cells = _cells(n_parts, rng)
    cols = math.ceil(math.sqrt(len(cells)))
    rows = math.ceil(len(cells) / cols)
    size_x, size_y = cols * PITCH_MM, rows * PITCH_MM
    bx, by, bz = BLOCK_MM
    parts: list[dict[str, Any]] = []
    mates: list[dict[str, Any]] = []
    rules: list[dict[str, Any]] = []
    base_holes: list[dict[str, Any]] = []
    base: dict[str, Any] = {"name": "base", "material": "aluminium",
            "geometry": {"type": "box", "size": [size_x, size_y, BASE_T_MM], "holes": base_holes},
            "pose": {"xyz": [0.0, 0.0, BASE_T_MM / 2]}, "fixtured": True}
    parts.append(base)
    tray_slot = [0]

    def start(height_mm: float) -> dict[str, Any]:
        k = tray_slot[0]
        tray_slot[0] += 1
        per_row = max(cols * 2, 6)
        x = -size_x / 2 + 50.0 + TRAY_PITCH_MM * (k % per_row)
        y = -size_y / 2 - 120.0 - TRAY_PITCH_MM * (k // per_row)
        return {"location": "tray", "xyz": [_r(x), _r(y), _r(height_mm / 2)]}

    for ci, cell in enumerate(cells):
        cx = -size_x / 2 + PITCH_MM * (ci % cols + 0.5)
        cy = -size_y / 2 + PITCH_MM * (ci // cols + 0.5)
        below = "base"
        below_holes = base_holes
        below_top_z = BASE_T_MM
        below_centre = np.array([0.0, 0.0, BASE_T_MM / 2])
        top_name, top_z, top_holes = "", 0.0, None
        for lv in range(cell["levels"]):
            name = f"c{ci}_block{lv}"
            zc = BASE_T_MM + bz * lv + bz / 2
            holes: list[dict[str, Any]] = []
            for s, tag in ((-1, "a"), (1, "b")):
                hole_name = f"h_{name}_{tag}" if below == "base" else f"h{tag}"
                below_holes.append({"name": hole_name,
                                    "at": [_r(cx + s * PIN_X_MM - below_centre[0]),
                                           _r(cy - below_centre[1]),
                                           _r(below_top_z - below_centre[2])],
                                    "diameter": PIN_D_MM, "depth": PIN_L_MM + 2.0, "chamfer": 0.5})
                mates.append({"name": f"{name}_pin_{tag}", "pin": f"{name}.p{tag}",
                              "hole": f"{below}.{hole_name}", **fit_spec})
            block = {"name": name, "material": "aluminium" if lv % 2 == 0 else "pom",
                     "geometry": {"type": "box", "size": [bx, by, bz], "holes": holes,
                                  "pins": [{"name": f"p{tag}", "at": [s * PIN_X_MM, 0.0, -bz / 2],
                                            "axis": [0.0, 0.0, -1.0], "diameter": PIN_D_MM,
                                            "length": PIN_L_MM, "chamfer": 0.5}
                                           for s, tag in ((-1, "a"), (1, "b"))]},
                     "pose": {"xyz": [_r(cx), _r(cy), _r(zc)]},
                     "start": start(bz + 2 * PIN_L_MM)}
            parts.append(block)
            below, below_holes, below_top_z = name, holes, zc + bz / 2
            below_centre = np.array([cx, cy, zc])
            top_name, top_z, top_holes = name, zc + bz / 2, holes
        top_centre = below_centre
        side_name = None
        if cell["side"] is not None:
            ax = 0 if cell["side"] == "+x" else 1
            e = np.eye(3)[ax]
            side_name = f"c{ci}_side"
            face = (bx if ax == 0 else by) / 2
            # the plate stands on the base (SIDE_GAP_MM above it when seated, so the pin, not
            # the base, locates it) up to the top block's top; its pin at the block's centre
            height = top_z - BASE_T_MM - SIDE_GAP_MM
            size = [SIDE_T_MM, SIDE_W_MM, height] if ax == 0 else [SIDE_W_MM, SIDE_T_MM, height]
            centre = top_centre + e * (face + SIDE_T_MM / 2)
            centre[2] = BASE_T_MM + SIDE_GAP_MM + height / 2
            pin_at = -e * SIDE_T_MM / 2 + np.array([0.0, 0.0, top_centre[2] - centre[2]])
            assert top_holes is not None
            top_holes.append({"name": "hs", "at": [_r(v) for v in e * face], "axis": e.tolist(),
                              "diameter": SIDE_PIN_D_MM, "depth": PIN_L_MM + 2.0, "chamfer": 0.4})
            parts.append({"name": side_name, "material": "steel",
                          "geometry": {"type": "box", "size": size,
                                       "pins": [{"name": "p", "at": [_r(v) for v in pin_at],
                                                 "axis": (-e).tolist(), "diameter": SIDE_PIN_D_MM,
                                                 "length": PIN_L_MM, "chamfer": 0.4}]},
                          "pose": {"xyz": [_r(v) for v in centre]},
                          "start": start(height)})
            mates.append({"name": f"{side_name}_pin", "pin": f"{side_name}.p",
                          "hole": f"{top_name}.hs", **fit_spec})
        if cell["cover"]:
            name = f"c{ci}_cover"
            if side_name is None:
                # flat cover pinned into the top block's top face
                assert top_holes is not None
                for s, tag in ((-1, "a"), (1, "b")):
                    top_holes.append({"name": f"hc{tag}", "at": [s * PIN_X_MM, 0.0, bz / 2],
                                      "diameter": PIN_D_MM, "depth": PIN_L_MM + 2.0, "chamfer": 0.5})
                    mates.append({"name": f"{name}_pin_{tag}", "pin": f"{name}.p{tag}",
                                  "hole": f"{top_name}.hc{tag}", **fit_spec})
                parts.append({"name": name, "material": "aluminium",
                              "geometry": {"type": "box", "size": [50.0, 50.0, COVER_T_MM],
                                           "pins": [{"name": f"p{tag}",
                                                     "at": [s * PIN_X_MM, 0.0, -COVER_T_MM / 2],
                                                     "axis": [0.0, 0.0, -1.0], "diameter": PIN_D_MM,
                                                     "length": PIN_L_MM, "chamfer": 0.5}
                                                    for s, tag in ((-1, "a"), (1, "b"))]},
                              "pose": {"xyz": [_r(cx), _r(cy), _r(top_z + COVER_T_MM / 2)]},
                              "start": start(COVER_T_MM + PIN_L_MM)})
            else:
                # L-cover resting on the top block, its flange in front of the side plate
                ax = 0 if cell["side"] == "+x" else 1
                e = np.eye(3)[ax]
                face = (bx if ax == 0 else by) / 2
                inner = -face - 2.0
                outer = face + SIDE_T_MM + FLANGE_GAP_MM + FLANGE_T_MM
                length = outer - inner
                plate_c = e * (inner + outer) / 2
                plate_size = [length, 50.0, COVER_T_MM] if ax == 0 else [50.0, length, COVER_T_MM]
                flange_c = e * (outer - FLANGE_T_MM / 2)
                drop = FLANGE_DROP_MM + COVER_T_MM
                flange_c = flange_c + np.array([0.0, 0.0, COVER_T_MM / 2 - drop / 2])
                flange_size = [FLANGE_T_MM, 40.0, drop] if ax == 0 else [40.0, FLANGE_T_MM, drop]
                centre = np.array([cx, cy, top_z + COVER_T_MM / 2])
                parts.append({"name": name, "material": "aluminium",
                              "geometry": {"type": "composite", "children": [
                                  {"shape": "box", "size": plate_size,
                                   "pose": {"xyz": [_r(v) for v in plate_c]}},
                                  {"shape": "box", "size": flange_size,
                                   "pose": {"xyz": [_r(v) for v in flange_c]}}]},
                              "pose": {"xyz": [_r(v) for v in centre]},
                              "start": start(drop)})
            rules.append({"before": top_name, "after": name,
                          "reason": "the block is screwed down before the cover hides the screws"})
    # the table (centred on the product frame) covers the base and every tray slot
    starts = np.array([p["start"]["xyz"][:2] for p in parts if "start" in p] or [[0.0, 0.0]])
    reach = np.maximum(np.abs(starts).max(axis=0) + TRAY_PITCH_MM, [size_x / 2, size_y / 2])
    table_x = max(2.0 * reach[0] + 200.0, 800.0)
    table_y = max(2.0 * reach[1] + 200.0, 600.0)
    doc: dict[str, Any] = {
        "asmplan": 1,
        "product": f"generated_{n_parts}_s{seed}",
        "description": f"Generated: {len(cells)} cells on a {cols}x{rows} grid, seed {seed}.",
        "units": {"length": "mm", "mass": "g", "angle": "deg"},
        "parts": parts,
        "mates": mates,
        "precedence": {"base": "base", "rules": rules},
        "resources": {
            "gripper": {"stroke": 85.0, "finger": {"size": [20.0, 8.0, 30.0], "friction": 1.0},
                        "max_force": 60.0, "mass": 600.0},
            "table": {"size": [_r(table_x), _r(table_y), 40.0], "friction": 0.5},
            "fixtures": [{"name": "vise", "holds": "base"}],
        },
    }
    if not base_holes:
        del base["geometry"]["holes"]
    for part in parts:
        geom = part["geometry"]
        if "holes" in geom and not geom["holes"]:
            del geom["holes"]
    return doc


def product_yaml(doc: dict[str, Any]) -> str:
    """The document as YAML text (block style, key order kept)."""
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=110)


def generated_product(n_parts: int, seed: int, *, fit: str | float = "H7/g6") -> Product:
    """:func:`generate_product`, validated and built like a file would be."""
    doc = generate_product(n_parts, seed, fit=fit)
    located = parse_located(product_yaml(doc), f"<generated {n_parts} parts, seed {seed}>")
    return build_product(located, Path.cwd())


__all__ = ["generate_product", "generated_product", "product_yaml"]
