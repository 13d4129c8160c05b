"""One cache of everything geometric about a product: :class:`ProductGeometry`.

The planner, the simulator and the checks share one ``ProductGeometry(product)``; every
quantity is computed on first use, per part, and kept: the part's shape at fitted sizes, its
exact solid and mesh, mass properties, feature frames and depths, the collision model at each
level of detail with its measured error, and the FCL geometries (BVH trees are built once).

Parts of the same shape (a product's repeated blocks, pins and plates) share one solid and
one set of convex pieces: those are computed once per distinct shape content (every size and
placement in the part frame, compared bit for bit) and are the same objects for each part.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable, Mapping
from functools import cached_property
from typing import TypeVar, cast

import numpy as np

from ..knowledge.errors import InputIssue, ProductError
from ..knowledge.model import Feature, Part, Product
from .collision import CollisionWorld, FclShapes
from .features import Finding, T_part_feature, check_feature, feature_depth
from .geometry import (
    FeatureSizing,
    GeometryError,
    GeometrySettings,
    HoleShape,
    PartShape,
    fitted_sizes,
    manifold_to_mesh,
    part_shape,
    shape_solid,
    trimesh_to_manifold,
)
from .lod import (
    LEVELS,
    bodies,
    coarse_pieces,
    convex_pieces,
    exact_model,
    hole_sides,
)
from .lod_measure import LevelReport, measure, with_errors
from .mass import MassProperties, mass_properties
from .mesh import TriangleMesh
from .meshfile import LoadedMesh, MeshFileError, load_mesh_file
from .pieces import CollisionModel, ConvexPiece, LevelOfDetail
from .primitive_pieces import HoleSides

_T = TypeVar("_T")


class ProductGeometry:
    """Lazily computed, cached geometry of every part of ``product``.

    Parameters
    ----------
    product : Product
    settings : GeometrySettings, optional

    Raises
    ------
    ProductError
        (from the accessors) when a part's mesh file cannot be used; the issue points at the
        part's ``geometry.file`` in the product file.
    """

    def __init__(self, product: Product, settings: GeometrySettings | None = None):
        self.product = product
        self.settings = settings or GeometrySettings()
        self.fcl_shapes = FclShapes()
        self._cache: dict[tuple[str, str], object] = {}
        self._by_content: dict[tuple[object, ...], object] = {}  # see _shared
        self.timings_s: dict[str, float] = {}

    # -- plumbing -------------------------------------------------------------------------------
    def _get(self, kind: str, part: str, make: Callable[[], _T]) -> _T:
        key = (kind, part)
        if key not in self._cache:
            t = time.perf_counter()
            self._cache[key] = make()
            self.timings_s[kind] = self.timings_s.get(kind, 0.0) + time.perf_counter() - t
        return cast(_T, self._cache[key])

    def _shared(self, kind: str, content: object, make):
        """``make()`` once per distinct ``content`` (a value of :func:`_content_key`)."""
        key = (kind, content)
        if key not in self._by_content:
            self._by_content[key] = make()
        return self._by_content[key]

    def _part(self, name: str) -> Part:
        return self.product.part(name)

    @cached_property
    def sizing(self) -> FeatureSizing:
        """Fitted diameters of all mated features."""
        return fitted_sizes(self.product)

    def _input_error(self, part: str, message: str, key: str | None = "file") -> ProductError:
        idx = self.product.part_names.index(part)
        path: tuple[str | int, ...] = ("parts", idx, "geometry") + ((key,) if key else ())
        try:
            from ..knowledge.yamlsource import load_located

            return ProductError([load_located(self.product.source).issue(path, message)])
        except ProductError:
            where = f"parts[{idx}].geometry" + (f".{key}" if key else "")
            return ProductError([InputIssue(str(self.product.source), 0, 0, where, message)])

    # -- solids ---------------------------------------------------------------------------------
    def shape(self, part: str) -> PartShape:
        return self._get("shape", part, lambda: part_shape(self._part(part), self.sizing))

    def loaded_mesh(self, part: str) -> LoadedMesh:
        """The repaired mesh of a mesh-file part (raises ProductError when unusable)."""
        def make() -> LoadedMesh:
            g = self._part(part).geometry
            if g.mesh_file is None:
                raise self._input_error(part, "geometry: expected a mesh file, found none")
            try:
                return load_mesh_file(g.mesh_file, g.mesh_scale, self.settings, body=g.mesh_body)
            except MeshFileError as exc:
                raise self._input_error(part, f"mesh file {exc}") from None
        return self._get("mesh_file", part, make)

    def solid(self, part: str):
        """The exact manifold3d solid (part frame), pins included."""
        def make():
            sh = self.shape(part)
            if sh.is_mesh:
                try:
                    return trimesh_to_manifold(self.loaded_mesh(part).mesh)
                except ValueError as exc:
                    raise self._input_error(part, f"mesh file: {exc}") from None
            tol = self.settings.exact_tolerance_m
            return self._shared("solid", _content_key(sh, _NAMES), lambda: shape_solid(sh, tol))
        return self._get("solid", part, make)

    def _solid_without_pins(self, part: str):
        def make():
            sh = self.shape(part)
            if not sh.pins:
                return self.solid(part)
            tol = self.settings.exact_tolerance_m
            return self._shared("solid_np", _content_key(sh, _NAMES),
                                lambda: shape_solid(sh, tol, with_pins=False))
        return self._get("solid_np", part, make)

    def mesh(self, part: str) -> TriangleMesh:
        """The exact watertight mesh of the part (part frame, metres); ``.to_trimesh()`` gives
        it as a trimesh."""
        def make() -> TriangleMesh:
            if self.shape(part).is_mesh:
                loaded = self.loaded_mesh(part).mesh
                return TriangleMesh(loaded.vertices, loaded.faces)
            return manifold_to_mesh(self.solid(part))
        return self._get("mesh", part, make)

    def mass_properties(self, part: str) -> MassProperties:
        return self._get("mass", part, lambda: mass_properties(self._part(part), self.mesh(part)))

    # -- features -------------------------------------------------------------------------------
    def feature_frames(self, part: str) -> Mapping[str, np.ndarray]:
        """``{feature: T_part_feature (4, 4)}``."""
        features = self._part(part).features
        return self._get("frames", part, lambda: {f.name: T_part_feature(f) for f in features})

    def feature_depth(self, feature: Feature) -> float:
        """Hole depth or pin length (m); through holes measured on the solid."""
        key = f"{feature.part}.{feature.name}"
        return self._get("depth", key, lambda: feature_depth(self.solid(feature.part), feature,
                                                             self.sizing.diameter(feature)))

    def feature_findings(self, part: str) -> tuple[Finding, ...]:
        """Material probes of every feature of ``part`` against its solid."""
        def make():
            out: list[Finding] = []
            solid = self.solid(part)
            for f in self._part(part).features:
                out += check_feature(solid, f, self.feature_depth(f), self.sizing.diameter(f))
            return tuple(out)
        return self._get("feature_findings", part, make)

    def holes(self, part: str) -> tuple[HoleShape, ...]:
        """Holes as cut (primitive parts) or as declared (mesh parts), for measurements."""
        def make():
            sh = self.shape(part)
            if not sh.is_mesh:
                return sh.holes
            out = []
            for f in self._part(part).features:
                if not f.is_male:
                    out.append(HoleShape(f.name, T_part_feature(f), 0.5 * self.sizing.diameter(f),
                                         self.feature_depth(f), f.through, f.chamfer_m))
            return tuple(out)
        return self._get("holes", part, make)

    def hole_sides(self, part: str) -> dict[str, HoleSides]:
        rc = {k[1]: v for k, v in self.sizing.radial_clearance_m.items() if k[0] == part}
        sh = self.shape(part)
        probe = PartShape(sh.part, sh.bodies, self.holes(part), sh.pins, sh.is_mesh)
        return self._get("sides", part, lambda: hole_sides(probe, rc, self.settings))

    # -- collision models -----------------------------------------------------------------------
    def _raw_model(self, part: str, level: LevelOfDetail) -> CollisionModel:
        def make() -> CollisionModel:
            sh = self.shape(part)
            mesh = self.mesh(part) if sh.is_mesh else None
            if level == "exact":
                solid = None if sh.is_mesh or not sh.holes else self._solid_without_pins(part)
                return exact_model(sh, self.settings, solid, mesh)
            if level == "coarse":  # the hull of the convex pieces (computed once, cached)
                pieces = self._raw_model(part, "convex").pieces
                return CollisionModel("coarse", coarse_pieces(sh, pieces, self.settings, mesh),
                                      notes=("one convex hull (holes filled)",))
            sides = self.hole_sides(part)
            if sh.is_mesh:
                pieces, notes = convex_pieces(sh, sides, self.settings, mesh, self.holes(part))
            else:  # pieces and notes name features, so equal shapes must have equal names too
                pieces, notes = self._shared(
                    "convex", _content_key((sh, sides), _PART_NAME),
                    lambda: convex_pieces(sh, sides, self.settings, mesh, ()))
            return CollisionModel("convex", pieces, notes=notes)
        return self._get(f"raw_{level}", part, make)

    def level_report(self, part: str, level: LevelOfDetail) -> LevelReport:
        """How far ``part``'s model at ``level`` is from the exact geometry (measured for
        convex and coarse; the analytic polygon bound for exact)."""
        if level not in LEVELS:
            raise ValueError(f"level: expected one of {', '.join(LEVELS)}, found {level!r}")

        def make() -> LevelReport:
            model = self._raw_model(part, level)
            if level == "exact":
                return LevelReport("exact", len(model.pieces) + (model.mesh_faces is not None),
                                   model.hausdorff_m, False, (), model.notes)
            spans = {}
            for h in self.holes(part):
                d = self.feature_depth(self._part(part).feature(h.feature))
                if d > 0:
                    spans[h.feature] = (-0.75 * d, -0.25 * d)
            sides = self.hole_sides(part)
            return measure(model, level, self.solid(part), self.holes(part), sides, self.settings, spans)
        return self._get(f"report_{level}", part, make)

    def collision_model(self, part: str, level: LevelOfDetail = "convex", *,
                        measured: bool = True) -> CollisionModel:
        """``part``'s collision model at ``level`` carrying its measured error.

        ``measured=False`` returns the same pieces without measuring them (``hausdorff_m``
        and ``hole_clearance_error_m`` 0; the measurement takes ~0.1-1 s per part), cached too.
        """
        if level not in LEVELS:
            raise ValueError(f"level: expected one of {', '.join(LEVELS)}, found {level!r}")
        if level == "exact" or not measured:
            return self._raw_model(part, level)
        return self._get(f"model_{level}", part,
                         lambda: with_errors(self._raw_model(part, level), self.level_report(part, level)))

    def bodies(self, part: str, level: LevelOfDetail = "convex") -> tuple[tuple[ConvexPiece, ...], ...]:
        """The level's pieces in groups of at most ``settings.max_pieces_per_body``."""
        return bodies(self.collision_model(part, level), self.settings.max_pieces_per_body)

    def collision_world(self, level: LevelOfDetail = "convex",
                        poses: Mapping[str, np.ndarray] | None = None,
                        parts: Iterable[str] | None = None) -> CollisionWorld:
        """A new world with ``parts`` (default all) at ``poses`` (default: assembled poses).

        The world shares this object's FCL geometry cache.
        """
        world = CollisionWorld(self.fcl_shapes)
        names = list(parts) if parts is not None else list(self.product.part_names)
        for name in names:
            T = poses[name] if poses is not None and name in poses else self.product.T_world_assembled(name)
            world.add(name, self.collision_model(name, level), T)
        return world

    def build(self, level: LevelOfDetail = "exact") -> dict[str, float]:
        """Compute every part's model at ``level`` now; returns seconds per stage."""
        for name in self.product.part_names:
            try:
                self.collision_model(name, level)
            except GeometryError as exc:
                raise self._input_error(name, str(exc), key=None) from None
        return dict(self.timings_s)


_PART_NAME = frozenset({"part", "notes"})  # PartShape fields that do not shape anything
_NAMES = _PART_NAME | {"feature"}  # ... nor do feature names shape a solid


def _content_key(value: object, skip: frozenset[str] = frozenset()) -> object:
    """A hashable key, equal for values of equal content: dataclasses field by field (fields
    named in ``skip`` left out), arrays by dtype, shape and bytes, floats by their bits (so
    -0.0 and 0.0 differ), containers item by item."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__qualname__, tuple(
            (f.name, _content_key(getattr(value, f.name), skip))
            for f in dataclasses.fields(value) if f.name not in skip))
    if isinstance(value, np.ndarray):
        return ("ndarray", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, float):
        return ("float", float(value).hex())
    if isinstance(value, np.generic):
        return ("numpy", value.dtype.str, value.tobytes())
    if isinstance(value, tuple | list):
        return (type(value).__name__, tuple(_content_key(v, skip) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple((_content_key(k, skip), _content_key(v, skip))
                              for k, v in value.items()))
    if value is None or isinstance(value, str | int):  # bool is an int
        return (type(value).__name__, value)
    raise TypeError(f"no content key for {type(value).__name__}")


__all__ = ["ProductGeometry"]
