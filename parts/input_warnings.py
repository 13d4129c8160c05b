"""Warnings about a product's geometry input that do not stop it from loading: what a reader
should know before trusting a plan (a multi-body file fused into one part, a declared feature
that the level of detail used for contact fills or bridges).

``validate`` and ``sequence`` print them; each names the part and the file. ``validate`` also
reports, as input errors, every ``geometry.body`` that names no body of its STEP file
(:func:`body_issues`; the other commands meet it when they load the part).
"""

from __future__ import annotations

from ..knowledge.errors import InputIssue
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


def body_issues(product: Product) -> list[InputIssue]:
    """Every ``geometry.body`` of the product that names no body of its STEP file (or whose
    file cannot be read as STEP), located at that key in the product file; all at once."""
    from ..knowledge.yamlsource import load_located
    from .meshfile import MeshFileError, check_step_body

    issues: list[InputIssue] = []
    for idx, part in enumerate(product.parts):
        g = part.geometry
        if g.kind != "mesh" or g.mesh_file is None or g.mesh_body is None:
            continue
        try:
            check_step_body(g.mesh_file, g.mesh_body)
        except MeshFileError as exc:
            path: tuple[str | int, ...] = ("parts", idx, "geometry", "body")
            message = f"mesh file {exc}"
            try:
                issues.append(load_located(product.source).issue(path, message))
            except Exception:  # the source is not a readable YAML file: name the key only
                issues.append(InputIssue(str(product.source), 0, 0,
                                         f"parts[{idx}].geometry.body", message))
    return issues


__all__ = ["body_issues", "geometry_warnings"]
