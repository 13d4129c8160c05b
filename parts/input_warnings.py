"""Warnings about a product's geometry input that do not stop it from loading: what a reader
should know before trusting a plan (a multi-body file fused into one part, a declared feature
that the level of detail used for contact fills or bridges).

``validate`` and ``sequence`` print them; each names the part and the file.
"""

from __future__ import annotations

from ..knowledge.model import Product
from .models import ProductGeometry


def geometry_warnings(product: Product, geometry: ProductGeometry | None = None) -> list[str]:
    """One sentence per warning, naming the part.

    A STEP file with several bodies referenced without ``body:`` is fused into one part: the
    warning names its bodies (read through cascadio; a missing cascadio gives no warning here,
    the load itself reports it). A declared feature of a mesh part that the convex level
    fills or bridges is named with its part (:func:`asmplan.parts.feature_levels.level_warnings`;
    ``geometry``: the product's, if already built).
    """
    from .feature_levels import level_warnings
    from .meshfile import MeshFileError, multi_body_warning, step_body_names

    out: list[str] = []
    seen: dict[str, list[str]] = {}
    for part in product.parts:
        g = part.geometry
        if g.kind != "mesh" or g.mesh_file is None or g.mesh_body is not None:
            continue
        if g.mesh_file.suffix.lower() not in (".step", ".stp"):
            continue
        key = str(g.mesh_file)
        if key not in seen:
            try:
                seen[key] = step_body_names(g.mesh_file)
            except MeshFileError:
                seen[key] = []
        if len(seen[key]) > 1:
            out.append(f'part "{part.name}": {multi_body_warning(g.mesh_file, seen[key])}')
    return out + level_warnings(product, geometry)


__all__ = ["geometry_warnings"]
