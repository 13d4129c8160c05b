"""Builds the ``parts`` section of a product document: each part's material, geometry
(mesh, primitives, compound, holes and pins), features and handling."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .build_base import BuilderBase, _pose, _unit
from .errors import did_you_mean
from .materials import Material
from .model import MALE_KINDS, Feature, Geometry, GraspHint, Handling, HoleCut, Part, PinAdd, Primitive
from .product_schema import LENGTH_UNITS, PART
from .schema import INVALID
from .yamlsource import PathKey


class PartsBuilder(BuilderBase):
    """Builds the ``parts`` section: every part's material, geometry, features and handling."""

    # -- parts -----------------------------------------------------------------------------
    def build_parts(self, raw_parts: list[Any], materials: dict[str, Material]) -> dict[str, Part]:
        parts: dict[str, Part] = {}
        first_line: dict[str, int] = {}
        for i, raw in enumerate(raw_parts):
            path: PathKey = ("parts", i)
            v = PART.check(raw, path, self.ctx)
            name = raw.get("name") if isinstance(raw, dict) else None
            if isinstance(name, str):
                if name in first_line:
                    self.err((*path, "name"), f'duplicate part name "{name}" (first defined on '
                             f"line {first_line[name]})")
                    continue
                first_line[name] = self.doc.where((*path, "name"))[0]
                if "." in name:
                    self.err((*path, "name"), f'expected a part name without ".", found "{name}"')
                    continue
            if v is INVALID:
                # still report an unknown material of a part that has other errors too
                if isinstance(raw, dict) and isinstance(raw.get("material"), str):
                    self.material(raw["material"], (*path, "material"), materials)
                continue
            part = self.build_part(v, path, materials)
            if part is not None:
                parts[part.name] = part
        return parts

    def build_part(self, v: dict[str, Any], path: PathKey, materials: dict[str, Material]
                   ) -> Part | None:
        name = v["name"]
        material = None
        if v["material"] is not None:
            material = self.material(v["material"], (*path, "material"), materials)
            if material is None:
                return None
        elif v["mass"] is None:
            self.err(path, 'expected "material" (to compute the mass) or "mass", found neither')
            return None
        friction = v["friction"] if v["friction"] is not None else (
            material.friction if material else 0.6)
        color = tuple(v["color"]) if v["color"] else (material.color_rgb if material else (0.7, 0.7, 0.7))
        geometry = self.build_geometry(v["geometry"], (*path, "geometry"), name)
        if geometry is None:
            return None
        features = self.build_features(name, v, geometry, path)
        if features is None:
            return None
        T_product_part = _pose(v["pose"])
        if v["start"] is None:
            T_world_start, location = None, "table"
        else:
            T_world_start, location = _pose(v["start"]), v["start"]["location"]
        handling = self.build_handling(v["handling"])
        return Part(name=name, geometry=geometry, T_product_part=T_product_part,
                    T_world_start=T_world_start if T_world_start is not None else np.full((4, 4), np.nan),
                    start_location=location, material=material, mass_kg=v["mass"],
                    friction=friction, color_rgb=color, features=features, handling=handling,
                    fixtured=v["fixtured"])

    def material(self, name: str, path: PathKey, materials: dict[str, Material]) -> Material | None:
        if name in materials:
            return materials[name]
        self.err(path, f'unknown material "{name}"{did_you_mean(name, materials)}; known materials: '
                 f"{', '.join(sorted(materials))}")
        return None

    # Complexity above C (radon): one branch per geometry type (mesh, box, cylinder, sphere,
    # compound) and per hole or pin check, each with its own message.
    def build_geometry(self, g: dict[str, Any], path: PathKey, part: str) -> Geometry | None:
        kind = g["type"]
        if kind == "mesh":
            file = Path(g["file"])
            full = file if file.is_absolute() else self.base_dir / file
            if not full.is_file():
                self.err((*path, "file"), f'mesh file not found: expected a file at "{full}"')
                return None
            if full.suffix.lower() not in (".stl", ".obj", ".ply", ".step", ".stp", ".glb", ".off"):
                self.err((*path, "file"), f'expected an STL, OBJ, PLY, OFF, GLB or STEP file, found '
                         f'"{full.suffix}"')
                return None
            scale = LENGTH_UNITS[g["units"]] if g["units"] else self.ctx.scales["length"]
            if g.get("body") is not None and full.suffix.lower() not in (".step", ".stp"):
                self.err((*path, "body"), f'expected "body" only with a multi-body STEP file, found a '
                         f'{full.suffix} file', key=True)
                return None
            return Geometry(kind="mesh", mesh_file=full, mesh_scale=scale, mesh_body=g.get("body"))
        prims: tuple[Primitive, ...]
        if kind == "box":
            prims = (Primitive("box", np.eye(4), size_m=tuple(g["size"])),)
        elif kind == "cylinder":
            prims = (Primitive("cylinder", np.eye(4), diameter_m=g["diameter"], length_m=g["length"]),)
        elif kind == "sphere":
            prims = (Primitive("sphere", np.eye(4), diameter_m=g["diameter"]),)
        else:
            prims = tuple(
                Primitive(c["shape"], _pose(c["pose"]), size_m=tuple(c.get("size") or (0, 0, 0)),
                          diameter_m=c.get("diameter") or 0.0, length_m=c.get("length") or 0.0)
                for c in g["children"])
        holes = tuple(HoleCut(h["name"], np.asarray(h["at"]), _unit(h["axis"]), h["diameter"],
                              h["depth"] or 0.0, h["through"], h["chamfer"])
                      for h in g.get("holes") or [])
        pins = tuple(PinAdd(p["name"], np.asarray(p["at"]), _unit(p["axis"]), p["diameter"],
                            p["length"], p["chamfer"]) for p in g.get("pins") or [])
        ok = True
        for i, h in enumerate(holes):
            if h.chamfer_m * 2 >= h.diameter_m:
                ok = False
                self.err((*path, "holes", i, "chamfer"), f"expected a chamfer smaller than the "
                         f"radius {h.diameter_m / 2 * 1e3:g} mm, found {h.chamfer_m * 1e3:g} mm")
            elif not h.through and h.chamfer_m >= h.depth_m:
                ok = False
                self.err((*path, "holes", i, "chamfer"), f"expected a chamfer shallower than the "
                         f"hole's depth {h.depth_m * 1e3:g} mm, found {h.chamfer_m * 1e3:g} mm")
        for i, p in enumerate(pins):
            if p.chamfer_m * 2 >= p.diameter_m:
                ok = False
                self.err((*path, "pins", i, "chamfer"), f"expected a chamfer smaller than the "
                         f"radius {p.diameter_m / 2 * 1e3:g} mm, found {p.chamfer_m * 1e3:g} mm")
        return Geometry(kind=kind, primitives=prims, holes=holes, pins=pins) if ok else None

    def build_features(self, part: str, v: dict[str, Any], geometry: Geometry, path: PathKey
                       ) -> tuple[Feature, ...] | None:
        features: list[Feature] = []
        where: dict[str, PathKey] = {}
        ok = True

        def add(f: Feature, fpath: PathKey) -> None:
            nonlocal ok
            if f.name in where:
                ok = False
                self.err((*fpath, "name"), f'duplicate feature name "{f.name}" in part "{part}" '
                         f"(first defined on line {self.doc.where((*where[f.name], 'name'))[0]})")
                return
            where[f.name] = fpath
            self.feature_paths[(part, f.name)] = fpath
            features.append(f)

        for i, h in enumerate(geometry.holes):
            add(Feature(part, h.feature, "hole", h.origin_m, h.axis, h.diameter_m, h.depth_m,
                        h.chamfer_m, h.through), (*path, "geometry", "holes", i))
        for i, p in enumerate(geometry.pins):
            add(Feature(part, p.feature, "pin", p.origin_m, p.axis, p.diameter_m, p.length_m,
                        p.chamfer_m), (*path, "geometry", "pins", i))
        for i, f in enumerate(v["features"]):
            fpath = (*path, "features", i)
            male = f["type"] in MALE_KINDS
            length = f["length"] if male else f["depth"]
            if length is None and not (f["through"] and not male):
                ok = False
                need = "length" if male else "depth"
                self.err(fpath, f'missing required key "{need}" for a {f["type"]} (a positive length)')
                continue
            wrong = "depth" if male else "length"
            if f[wrong] is not None:
                ok = False
                right = "length" if male else "depth"
                self.err((*fpath, wrong), f'a {f["type"]} has a "{right}", not a "{wrong}"', key=True)
                continue
            add(Feature(part, f["name"], f["type"], np.asarray(f["at"]), _unit(f["axis"]),
                        f["diameter"], length or 0.0, f["chamfer"], f["through"]), fpath)
        return tuple(features) if ok else None

    def build_handling(self, h: dict[str, Any] | None) -> Handling:
        if h is None:
            return Handling()
        grasp = None
        if h["grasp"] is not None:
            g = h["grasp"]
            grasp = GraspHint(closing_axis=_unit(g["closing_axis"]) if g["closing_axis"] else None,
                              approach_axis=_unit(g["approach_axis"]) if g["approach_axis"] else None,
                              width_m=g["width"],
                              offset_m=np.asarray(g["offset"]) if g["offset"] else None)
        return Handling(
            insertion_direction=_unit(h["insertion_direction"]) if h["insertion_direction"] else None,
            grasp=grasp, max_clamp_force_N=h["max_clamp_force"], max_speed_m_s=h["max_speed"],
            max_acceleration_m_s2=h["max_acceleration"], finger=h["finger"],
            operation=h["operation"], note=h["note"] or "")
