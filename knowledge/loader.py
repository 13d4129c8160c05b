"""Load a product YAML file into a validated :class:`~asmplan.knowledge.model.Product`.

Validation reports every problem at once with file, line, column, key path, what was
expected and what was found (:class:`~asmplan.knowledge.errors.ProductError`). The format is
documented in ``docs/product-format.md``.

The schema is :mod:`asmplan.knowledge.product_schema`; the ``parts`` section is built by
:mod:`asmplan.knowledge.build_parts`, the mates, default fits and precedence by
:mod:`asmplan.knowledge.build_mates`, on the shared state of :mod:`asmplan.knowledge.build_base`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .build_base import _pose
from .build_mates import MatesBuilder
from .build_parts import PartsBuilder
from .consistency import find_inconsistencies
from .errors import InputIssue, ProductError, did_you_mean
from .fit_rules import FitRule
from .materials import Material, builtin_materials
from .model import (
    Finger,
    Fixture,
    Gripper,
    Groove,
    Part,
    Press,
    Primitive,
    Process,
    Product,
    RegraspFixture,
    RegraspSeat,
    Resources,
    Robot,
    Table,
)
from .product_schema import DEFAULT_FIT, DOCUMENT, FORMAT_VERSION, LENGTH_UNITS
from .robot import JointLimit, UrdfError, read_urdf_arm, resolve_model
from .schema import INVALID, ListOf
from .yamlsource import Located, PathKey, load_located

# ---------------------------------------------------------------------------------------------
# Building the model
# ---------------------------------------------------------------------------------------------


def load_product(path: Path | str, *, display_name: str | None = None,
                 consistency: bool = True) -> Product:
    """Read, validate and convert a product file.

    Parameters
    ----------
    path : path to the YAML file. Mesh files it names are resolved relative to its folder.
    display_name : how to name the file in messages (default: ``path`` as given).
    consistency : also refuse contradictions between valid values (a pin off its hole's
        axis, a hole outside its part...; :mod:`asmplan.knowledge.consistency`). Turn off
        only to study such a product with the measuring checks of :mod:`asmplan.parts`.

    Raises
    ------
    ProductError
        With every problem found, each with file, line, column, key path, expected and found.
    """
    doc = load_located(path, display_name)
    return build_product(doc, Path(path).resolve().parent, consistency=consistency)


def build_robot(r: dict[str, Any], base_dir: Path,
                err: Callable[[PathKey, str], None]) -> Robot | None:
    """The cell's arm from the checked ``resources.robot`` mapping: resolve and read the
    URDF (:mod:`asmplan.knowledge.robot`), apply the joint-limit overrides. Problems go to
    ``err`` with their key path; returns None then."""
    where = ("resources", "robot")
    try:
        urdf = read_urdf_arm(resolve_model(r["model"], base_dir), r["flange"])
    except UrdfError as exc:
        err((*where, "flange" if r["flange"] and "flange" in str(exc) else "model"), str(exc))
        return None
    by_name = {j.name: j for j in urdf.joints}
    joints = dict(by_name)
    ok = True
    for name, o in r["joints"].items():
        if name not in by_name:
            err((*where, "joints", name), f'expected a joint of the arm ({", ".join(by_name)}), '
                f'found "{name}"{did_you_mean(name, by_name)}')
            ok = False
            continue
        j = by_name[name]
        lo = j.lower_rad if o["lower"] is None else o["lower"]
        hi = j.upper_rad if o["upper"] is None else o["upper"]
        if not lo < hi:
            err((*where, "joints", name), f"expected lower < upper, found {math.degrees(lo):g} "
                f">= {math.degrees(hi):g} deg")
            ok = False
            continue
        joints[name] = JointLimit(name, lo, hi, o["velocity"] or j.velocity_rad_s,
                                  o["acceleration"] or j.acceleration_rad_s2)
    if not ok:
        return None
    return Robot(r["model"], _pose(r["base"]), r["reach"], urdf_path=urdf.path,
                 T_flange_tcp=_pose(r["mounting"]), flange_link=urdf.flange_link,
                 joints=tuple(joints[j.name] for j in urdf.joints))


class _Builder(PartsBuilder, MatesBuilder):
    # Complexity above C (radon): the loader's top level: every section of the file is read in order
    # and every issue collected (units, header, materials, resources, parts, mates, consistency).
    def run(self) -> Product:
        data = self.doc.data
        if not isinstance(data, dict):
            raise ProductError([self.doc.issue((), "expected a YAML mapping at the top level "
                                               "(asmplan, product, parts, ...), found "
                                               f"{type(data).__name__}")])
        self.setup_units(data)
        top, _ = DOCUMENT.check_partial(data, (), self.ctx)
        if top is INVALID:
            raise ProductError(self.ctx.issues)
        if isinstance(top.get("asmplan"), int) and top["asmplan"] != FORMAT_VERSION:
            self.err(("asmplan",), f"expected format version {FORMAT_VERSION}, found {top['asmplan']}")

        materials = dict(builtin_materials())
        for name, m in (top.get("materials") or {}).items() if top.get("materials") else []:
            if m is not INVALID:
                E = m["elastic_modulus_gpa"]
                materials[name] = Material(name, m["density"], m["friction"],
                                           tuple(m["color"]) if m["color"] else (0.7, 0.7, 0.7),
                                           None if E is None else E * 1e9, m["poisson_ratio"])
        raw_parts: list[Any] = data["parts"] if isinstance(data.get("parts"), list) else []
        # every part name written down, even in a part that is otherwise invalid, so that
        # cross-references to it are not reported as unknown on top of the real error
        self.all_names: list[str] = [p["name"] for p in raw_parts if isinstance(p, dict)
                                     and isinstance(p.get("name"), str)]
        self.known_names = set(self.all_names)
        parts = self.build_parts(raw_parts, materials)
        gripper_etc = top.get("resources")
        process = self.build_process(top.get("process"))
        resources = self.build_resources(gripper_etc) if gripper_etc else None
        self.default_fits = self.build_default_fits(top.get("default_fits"), data.get("default_fits"))
        mates = self.build_mates(data.get("mates"), parts)
        precedence = self.build_precedence(top.get("precedence"), data.get("precedence"))
        if resources is not None:
            for i, fx in enumerate(resources.fixtures):
                self.check_part_ref(fx.holds, ("resources", "fixtures", i, "holds"))
            self.check_regrasp_fixtures(resources, parts)
            known = [f.name for f in resources.gripper.fingers]
            for i, raw in enumerate(raw_parts):
                h = raw.get("handling") if isinstance(raw, dict) else None
                finger = h.get("finger") if isinstance(h, dict) else None
                if isinstance(finger, str) and finger not in known:
                    names = ", ".join(known) or "none declared in resources.gripper.fingers"
                    self.err(("parts", i, "handling", "finger"),
                             f"expected one of the gripper's fingers ({names}), found "
                             f'"{finger}"{did_you_mean(finger, known)}')
        if self.ctx.issues:
            raise ProductError(self.ctx.issues)
        assert resources is not None  # a missing resources section is an issue above
        product = Product(
            name=top["product"], source=Path(self.doc.file), parts=tuple(parts.values()),
            mates=tuple(mates), precedence=precedence, process=process, resources=resources,
            T_world_product=_pose(top.get("placement")), description=top.get("description") or "",
            default_fits=self.default_fits or (),
        )
        if self.consistency:
            for found in find_inconsistencies(product):
                if found.subject[0] == "feature":
                    where = self.feature_paths[(found.subject[1], found.subject[2])]
                else:
                    where = self.mate_paths[found.subject[1]]
                self.err((*where, found.key) if found.key else where, found.message)
            if self.ctx.issues:
                raise ProductError(self.ctx.issues)
        return product

    # -- knowledge and resources -----------------------------------------------------------
    def build_process(self, v: dict[str, Any] | None) -> Process:
        if not v:
            return Process()
        names = {"max_speed": "max_speed_m_s", "max_acceleration": "max_acceleration_m_s2",
                 "insertion_speed": "insertion_speed_m_s", "max_insertion_force": "max_insertion_force_N",
                 "insertion_resistance": "insertion_resistance_N",
                 "lift_height": "lift_height_m", "approach_distance": "approach_distance_m",
                 "position_tolerance": "position_tolerance_m", "max_slip": "max_slip_m"}
        return Process(**{names.get(k, k): val for k, val in v.items()
                          if val is not None and val is not INVALID})

    def groove(self, finger: dict[str, Any], where: PathKey) -> Groove | None:
        """The pad's V-groove (SI), or None; a groove that does not fit the pad (angle not
        below 180 deg, deeper than the pad, wider than it at the face) is an error."""
        v = finger.get("groove")
        if not v:
            return None
        angle, depth = float(v["angle"]), float(v["depth"])
        width, thickness = float(finger["size"][0]), float(finger["size"][1])
        bad = False
        if not angle < math.pi:
            self.err((*where, "groove", "angle"), f"expected an included angle below 180 deg, "
                     f"found {math.degrees(angle):g} deg")
            bad = True
        elif depth * math.tan(0.5 * angle) >= 0.5 * width:
            self.err((*where, "groove", "depth"), f"expected a groove narrower than the pad at "
                     f"its face ({width * 1e3:g} mm), found {2e3 * depth * math.tan(0.5 * angle):g}"
                     f" mm (depth x 2 tan(angle / 2))")
            bad = True
        if depth >= thickness:
            self.err((*where, "groove", "depth"), f"expected a depth below the pad's thickness "
                     f"({thickness * 1e3:g} mm), found {depth * 1e3:g} mm")
            bad = True
        return None if bad else Groove(angle, depth)

    def build_resources(self, v: dict[str, Any]) -> Resources | None:
        if any(v.get(k) is INVALID for k in ("gripper", "table", "fixtures", "robot", "press", "units",
                                             "regrasp")):
            return None
        # the cell's own units (resources.units) were applied while reading it (_CellMap)
        units = v.get("units") or {}
        self.check_cell_scale(v, bool(units.get("length")))
        g = v["gripper"]
        if g["min_force"] > g["max_force"]:
            self.err(("resources", "gripper", "min_force"), f"expected min_force <= max_force "
                     f"({g['max_force']:g} N), found {g['min_force']:g} N")
        grooves = [self.groove(g["finger"], ("resources", "gripper", "finger"))]
        grooves += [self.groove(f, ("resources", "gripper", "fingers", i))
                    for i, f in enumerate(g["fingers"])]
        gripper = Gripper(stroke_m=g["stroke"], finger_size_m=np.asarray(g["finger"]["size"]),
                          finger_friction=g["finger"]["friction"], max_force_N=g["max_force"],
                          min_force_N=g["min_force"], mass_kg=g["mass"] or 0.5,
                          fingers=tuple(Finger(f["name"], np.asarray(f["size"]), f["friction"],
                                               grooves[i + 1])
                                        for i, f in enumerate(g["fingers"])),
                          finger_groove=grooves[0])
        seen: dict[str, int] = {}
        for i, f in enumerate(g["fingers"]):
            if f["name"] in seen:
                self.err(("resources", "gripper", "fingers", i, "name"),
                         f'expected a unique finger name, found "{f["name"]}" again (fingers['
                         f'{seen[f["name"]]}])')
            seen.setdefault(f["name"], i)
        table = Table(np.asarray(v["table"]["size"]), v["table"]["friction"])
        fixtures = tuple(Fixture(f["name"], f["holds"], f["kind"]) for f in v["fixtures"])
        robot = build_robot(v["robot"], self.base_dir, self.err) if v["robot"] else None
        press = Press(float(v["press"]["max_force"])) if v.get("press") else None
        regrasp = tuple(RegraspFixture(
            f["name"], _pose(f["pose"]),
            tuple(Primitive(c["shape"], _pose(c["pose"]), size_m=tuple(c.get("size") or (0, 0, 0)),
                            diameter_m=c.get("diameter") or 0.0, length_m=c.get("length") or 0.0)
                  for c in f["geometry"]),
            tuple(RegraspSeat(h["part"], _pose(h["pose"])) for h in f["holds"]),
            float(f["friction"])) for f in v["regrasp"] or ())
        return Resources(gripper, table, fixtures, robot, press=press, regrasp=regrasp)

    def check_regrasp_fixtures(self, resources: Resources, parts: dict[str, Part]) -> None:
        """``resources.regrasp``: unique names (not a part's or the table's), every seat a
        known part that is not fixtured, each part held once per fixture, and the fixture on
        the table (its lowest point at the table top, z = 0, within 0.01 mm)."""
        fixtured = {f.holds for f in resources.fixtures} | {n for n, p in parts.items()
                                                            if p.fixtured}
        seen: dict[str, int] = {}
        for i, fx in enumerate(resources.regrasp):
            where = ("resources", "regrasp", i)
            if fx.name in seen or fx.name in self.known_names or fx.name == "table":
                what = (f"regrasp[{seen[fx.name]}]" if fx.name in seen else
                        "the table" if fx.name == "table" else "a part")
                self.err((*where, "name"), f'expected a unique fixture name, found "{fx.name}" '
                         f"(also {what})")
            seen.setdefault(fx.name, i)
            held: set[str] = set()
            for k, seat in enumerate(fx.seats):
                at = (*where, "holds", k, "part")
                if not self.check_part_ref(seat.part, at):
                    continue
                if seat.part in fixtured:
                    self.err(at, f'expected a part the robot moves, found "{seat.part}", which is '
                             "fixtured in its assembled pose")
                if seat.part in held:
                    self.err(at, f'expected each part once per fixture, found "{seat.part}" again')
                held.add(seat.part)
            low = _lowest_z(fx)
            if abs(low) > 1e-5:
                self.err((*where, "pose"), f"expected the fixture on the table (its lowest point "
                         f"at z = 0), found its lowest point at z = {low * 1e3:.3f} mm")

    def check_cell_scale(self, v: dict[str, Any], own_units: bool) -> None:
        """A gripper stroke or a table out of any real cell's range means the product's length
        unit was applied to the cell by mistake (a product in cm: an 85 cm stroke, an 8 m table):
        an input error naming the value in mm, never a silent rescale."""
        unit = [k for k, s in LENGTH_UNITS.items() if s == self.ctx.scales["length"]]
        hint = ("" if own_units else f"; the document's length unit ({unit[0] if unit else '?'}) "
                "applies to resources unless they give their own: resources.units: {length: mm}")
        stroke = v["gripper"]["stroke"]
        if not 1e-3 <= stroke <= 0.5:
            self.err(("resources", "gripper", "stroke"), f"expected a gripper stroke of 1-500 mm, found "
                     f"{stroke * 1e3:.4g} mm{hint}")
        size = max(v["table"]["size"][:2])
        if not 0.05 <= size <= 20.0:  # 20 m: a long transfer line (a 2,000-part tray layout is 10.6 m)
            self.err(("resources", "table", "size"), f"expected a table of 50 mm to 20 m, found "
                     f"{size * 1e3:.4g} mm across{hint}")


def _lowest_z(fx: RegraspFixture) -> float:
    """Lowest world z of a fixture's primitives (box corners, cylinder rims, spheres), m."""
    low = math.inf
    for p in fx.primitives:
        T = fx.T_world_fixture @ p.T_part_shape
        if p.shape == "box":
            h = np.asarray(p.size_m, float) / 2
            z = T[2, 3] - float(np.abs(T[2, :3]) @ h)
        elif p.shape == "cylinder":
            ax = T[2, 2]
            z = (T[2, 3] - abs(ax) * p.length_m / 2
                 - math.sqrt(max(0.0, 1 - ax * ax)) * p.diameter_m / 2)
        else:
            z = T[2, 3] - p.diameter_m / 2
        low = min(low, float(z))
    return low


def load_default_fits(path: Path | str) -> tuple[FitRule, ...]:
    """The ``default_fits`` rules of a YAML file (a product file, or a file holding only
    ``units:`` and ``default_fits:``), for ``asmplan import --default-fits``.

    Raises
    ------
    ProductError
        With every problem found (file, line, key path, expected and found).
    """
    doc = load_located(path)
    b = _Builder(doc, Path(path).resolve().parent)
    data = doc.data
    if not isinstance(data, dict) or "default_fits" not in data:
        raise ProductError([doc.issue((), "expected a YAML mapping with a default_fits list")])
    b.setup_units(data)
    raw = ListOf(DEFAULT_FIT).check(data["default_fits"], ("default_fits",), b.ctx)
    rules = b.build_default_fits(raw, data["default_fits"])
    if b.ctx.issues:
        raise ProductError(b.ctx.issues)
    return rules or ()


def build_product(doc: Located, base_dir: Path, *, consistency: bool = True) -> Product:
    """Validate a parsed document and build the :class:`Product` (see :func:`load_product`)."""
    return _Builder(doc, base_dir, consistency).run()


__all__ = ["FORMAT_VERSION", "InputIssue", "ProductError", "build_product", "load_product"]
