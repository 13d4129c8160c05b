"""Start poses of the parts: given, fixtured, or laid out on the table beside the product.
"""

from __future__ import annotations

import numpy as np

from ..knowledge.model import Product
from ..parts.cell import regrasp_fixture_model
from .partdata import PartData
from .scene import piece_boxes


def initial_layout(product: Product, parts: dict[str, PartData]
                   ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Start pose of every part and a note on where it came from.

    A part without a start pose (NaN in the model) that is not fixtured is put on the table
    in its assembled orientation, lowest point on the table top, on a row beside the product
    (towards -y), left to right in part order, 20 mm apart and clear of every other start
    pose's footprint. Deterministic.

    A given start pose whose part reaches below the table top (a tray is not modelled; e.g.
    pins standing in a tray's pockets) is raised along world z until its lowest point rests on
    the table, and the note says by how much. Any other overlap is left for the layout check
    (:class:`StartInCollisionError`).
    """
    poses: dict[str, np.ndarray] = {}
    notes: dict[str, str] = {}
    boxes: list[np.ndarray] = []

    def footprint(name: str, T: np.ndarray) -> np.ndarray:
        pts = parts[name].points_m @ T[:3, :3].T + T[:3, 3]
        return np.stack([pts.min(axis=0), pts.max(axis=0)])

    for p in product.parts:
        if product.is_fixtured(p.name):
            poses[p.name] = product.T_world_assembled(p.name)
            notes[p.name] = "fixtured in its assembled pose"
            boxes.append(footprint(p.name, poses[p.name]))
        elif np.all(np.isfinite(p.T_world_start)):
            T = np.array(p.T_world_start, float)
            notes[p.name] = f"given: {p.start_location}"
            below = -float(footprint(p.name, T)[0, 2])
            if below > 1e-6:
                T[2, 3] += below
                notes[p.name] += (f"; raised by {below * 1e3:.2f} mm: the given pose reaches "
                                  "below the table top")
            poses[p.name] = T
            boxes.append(footprint(p.name, T))
    for fx in product.resources.regrasp:  # the cell's regrasp fixtures stand on the table
        pts = piece_boxes(regrasp_fixture_model(fx)).reshape(-1, 3)
        w = pts @ fx.T_world_fixture[:3, :3].T + fx.T_world_fixture[:3, 3]
        boxes.append(np.stack([w.min(axis=0), w.max(axis=0)]))
    size = np.asarray(product.resources.table.size_m, float)
    gap = 0.02
    for p in product.parts:
        if p.name in poses:
            continue
        T = product.T_world_assembled(p.name)
        fp = footprint(p.name, T)
        ext = fp[1] - fp[0]
        y_lo = min(b[0, 1] for b in boxes) if boxes else 0.0
        y = y_lo - gap - ext[1] / 2
        x = -size[0] / 2 + gap + ext[0] / 2
        while True:
            cand = np.stack([[x - ext[0] / 2, y - ext[1] / 2], [x + ext[0] / 2, y + ext[1] / 2]])
            if not any(np.all(cand[0] < b[1, :2] + gap) and np.all(b[0, :2] - gap < cand[1])
                       for b in boxes):
                break
            x += ext[0] + gap
            if x + ext[0] / 2 > size[0] / 2:
                x = -size[0] / 2 + gap + ext[0] / 2
                y -= ext[1] + gap
        Tn = T.copy()
        centre = 0.5 * (fp[0] + fp[1])
        Tn[:3, 3] += np.array([x - centre[0], y - centre[1], -fp[0, 2]])
        poses[p.name] = Tn
        boxes.append(footprint(p.name, Tn))
        notes[p.name] = (f"no start pose given: placed on the table at ({x * 1e3:.0f}, "
                         f"{y * 1e3:.0f}) mm in its assembled orientation, lowest point on the "
                         "table top")
    return poses, notes

