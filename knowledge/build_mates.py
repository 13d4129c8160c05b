"""Builds the ``mates``, ``default_fits`` and ``precedence`` sections of a product
document: part and feature references, ISO 286 fits and clearances, precedence rules and groups."""

from __future__ import annotations

from typing import Any

import networkx as nx

from . import iso286
from .build_base import BuilderBase
from .errors import did_you_mean
from .fit_rules import FitRule, builtin_rules, default_fit
from .model import FEMALE_KINDS, MALE_KINDS, AssemblyGroup, Feature, Mate, Part, Precedence, PrecedenceRule
from .product_schema import DEFAULT_FIT, MATE
from .schema import INVALID, Context
from .yamlsource import PathKey


class MatesBuilder(BuilderBase):
    """Builds the ``mates``, ``default_fits`` and ``precedence`` sections (part and feature
    references, fits and clearances, precedence rules); ``run`` sets the part names first."""

    all_names: list[str]
    known_names: set[str]
    default_fits: tuple[FitRule, ...] | None
    defaulted: dict[PathKey, tuple[str, str]]

    def check_part_ref(self, name: str, path: PathKey) -> bool:
        if name in self.known_names:
            return True
        self.err(path, f'unknown part "{name}"{did_you_mean(name, self.all_names)}; known parts: '
                 f'{", ".join(sorted(self.all_names))}')
        return False

    def build_mates(self, raw: Any, parts: dict[str, Part]) -> list[Mate]:
        mm_per_m = 1e3
        mates: list[Mate] = []
        if not isinstance(raw, list):
            return mates
        names: dict[str, int] = {}
        for i, item in enumerate(raw):
            path: PathKey = ("mates", i)
            v = MATE.check(item, path, self.ctx)
            if v is INVALID:
                continue
            pin = self.resolve_feature(v["pin"], (*path, "pin"), parts, MALE_KINDS)
            hole = self.resolve_feature(v["hole"], (*path, "hole"), parts, FEMALE_KINDS)
            if pin is None or hole is None:
                continue
            if pin.part == hole.part:
                self.err(path, "expected a pin and a hole on two different parts, found both on "
                         f'"{pin.part}"')
                continue
            name = v["name"] or f"{pin.ref}->{hole.ref}"
            if name in names:
                self.err((*path, "name"), f'duplicate mate name "{name}" (first on line {names[name]})')
                continue
            names[name] = self.doc.where(path)[0]
            self.mate_paths[name] = path
            given = [k for k in ("fit", "clearance", "interference") if v[k] is not None]
            if len(given) > 1:
                self.err((*path, given[1]), f"expected one of fit, clearance or interference, "
                         f"found {' and '.join(given)}", key=True)
                continue
            clearance = self.mate_clearance(v, path, pin, hole)
            if clearance is None:
                continue
            hub = v["hub_diameter"]
            if hub is not None and hub <= hole.diameter_m:
                self.err((*path, "hub_diameter"), f"expected a hub diameter larger than the hole "
                         f"{hole.ref} ({hole.diameter_m * mm_per_m:g} mm), found "
                         f"{hub * mm_per_m:g} mm")
                continue
            fit, source = ((iso286_normal(v["fit"]), None) if v["fit"]
                           else self.defaulted.pop(path, (None, None)))
            mates.append(Mate(name, pin.part, pin.name, hole.part, hole.name, *clearance,
                              fit=fit, hub_diameter_m=hub, fit_source=source))
        return mates

    def mate_clearance(self, v: dict[str, Any], path: PathKey, pin: Feature, hole: Feature
                       ) -> tuple[float, float] | None:
        mm = 1e3
        if v["fit"] is None and v["clearance"] is None and v["interference"] is None:
            if abs(pin.diameter_m - hole.diameter_m) <= 1e-9:  # line to line, as CAD draws
                return self.default_fit_clearance(path, pin, hole)
            c = hole.diameter_m - pin.diameter_m
            if c < 0:
                self.err(path, f"pin {pin.ref} ({pin.diameter_m * mm:g} mm) is larger than hole "
                         f"{hole.ref} ({hole.diameter_m * mm:g} mm); expected a clearance, or declare "
                         f'"interference" or an ISO "fit"')
                return None
            return c, c
        if abs(pin.diameter_m - hole.diameter_m) > 1e-9:
            key = next(k for k in ("fit", "clearance", "interference") if v[k] is not None)
            if key == "fit" and pin.diameter_m > hole.diameter_m:
                kind: str
                try:
                    kind = iso286.fit(v["fit"], hole.diameter_m).kind
                except iso286.FitError:
                    kind = "unknown"
                if kind == "clearance":
                    self.err((*path, "fit"), f"pin {pin.ref} ({pin.diameter_m * mm:g} mm) is larger "
                             f"than hole {hole.ref} ({hole.diameter_m * mm:g} mm) under the clearance "
                             f'fit "{v["fit"]}"; expected equal nominal diameters')
                    return None
            self.err((*path, key), f"expected equal nominal diameters for a {key} (the {key} gives "
                     f"the deviation), found pin {pin.ref} {pin.diameter_m * mm:g} mm and hole "
                     f"{hole.ref} {hole.diameter_m * mm:g} mm", key=True)
            return None
        if v["fit"] is not None:
            try:
                f = iso286.fit(v["fit"], hole.diameter_m)
            except iso286.FitError as exc:
                self.err((*path, "fit"), f'invalid ISO 286 fit "{v["fit"]}" at '
                         f"{hole.diameter_m * mm:g} mm: {exc}")
                return None
            return f.clearance_min_m, f.clearance_max_m
        if v["interference"] is not None:
            return -v["interference"], -v["interference"]
        c = v["clearance"]
        if isinstance(c, dict):
            if c["min"] > c["max"]:
                self.err((*path, "clearance"), f"expected min <= max, found min {c['min'] * mm:g} mm "
                         f"> max {c['max'] * mm:g} mm")
                return None
            return c["min"], c["max"]
        return c, c

    def build_default_fits(self, raw: Any, data: Any) -> tuple[FitRule, ...] | None:
        """The product's ``default_fits`` rules (None without the key). Each fit must be a
        valid ISO 286 fit over the rule's whole size range (checked at its ends)."""
        self.defaulted: dict[PathKey, tuple[str, str]] = {}
        if raw is None:
            return None
        if raw is INVALID:  # one rule failed its schema (reported): check the others too
            if not isinstance(data, list):
                return None
            quiet = Context(self.doc, self.ctx.scales, unit_names=self.ctx.unit_names)
            raw = [DEFAULT_FIT.check(r, ("default_fits", i), quiet) for i, r in enumerate(data)]
        rules: list[FitRule] = []
        for i, r in enumerate(raw):
            if r is INVALID:
                continue
            path: PathKey = ("default_fits", i)
            lo, hi = r["min_diameter"], r["max_diameter"]
            if lo >= hi:
                self.err((*path, "min_diameter"), f"expected min_diameter < max_diameter, found "
                         f"{lo * 1e3:g} mm >= {hi * 1e3:g} mm")
                continue
            try:
                for d in (hi, max(lo * (1 + 1e-9), min(hi, 1e-3))):
                    iso286.fit(r["fit"], d)
            except iso286.FitError as exc:
                self.err((*path, "fit"), f'expected an ISO 286 fit valid from {lo * 1e3:g} to '
                         f'{hi * 1e3:g} mm, found "{r["fit"]}": {exc}')
                continue
            rules.append(FitRule(r["male"], r["female"], hi, iso286_normal(r["fit"]), r["why"],
                                 lo, source=f"{self.doc.file}:{self.doc.where(path)[0]}"))
        return tuple(rules)

    def default_fit_clearance(self, path: PathKey, pin: Feature, hole: Feature
                              ) -> tuple[float, float] | None:
        """A line-to-line mate without a fit: the first matching rule of the product's
        ``default_fits`` (if any), then of the knowledge base's built-in rules
        (:mod:`asmplan.knowledge.fit_rules`), with or without the key."""
        rules = (*(self.default_fits or ()), *builtin_rules())
        rule = default_fit(pin.kind, hole.kind, hole.diameter_m, rules)
        if rule is None:
            self.err(path, f"expected a fit: no default_fits rule matches {pin.kind} {pin.ref} in "
                     f"{hole.kind} {hole.ref} at {hole.diameter_m * 1e3:g} mm (line to line)")
            return None
        try:
            f = iso286.fit(rule.fit, hole.diameter_m)
        except iso286.FitError as exc:
            self.err(path, f'default fit "{rule.fit}" ({rule.source}) at {hole.diameter_m * 1e3:g} mm: {exc}')
            return None
        self.defaulted[path] = (rule.fit, f"{rule.source}: {rule.why}" if rule.why else rule.source)
        return f.clearance_min_m, f.clearance_max_m

    def resolve_feature(self, ref: str, path: PathKey, parts: dict[str, Part],
                        kinds: tuple[str, ...]) -> Feature | None:
        if ref.count(".") != 1:
            self.err(path, f'expected a feature reference "part.feature", found "{ref}"')
            return None
        part_name, feat = ref.split(".")
        if not self.check_part_ref(part_name, path):
            return None
        part = parts.get(part_name)
        if part is None:  # the part itself is invalid; its error is reported already
            return None
        names = [f.name for f in part.features]
        if feat not in names:
            self.err(path, f'unknown feature "{feat}" on part "{part_name}"{did_you_mean(feat, names)}'
                     f'; its features: {", ".join(names) or "none"}')
            return None
        f = part.feature(feat)
        if f.kind not in kinds:
            self.err(path, f"expected a {' or '.join(kinds)}, found {ref} which is a {f.kind}")
            return None
        return f

    def build_precedence(self, v: dict[str, Any] | None, raw: Any) -> Precedence:
        if not v:
            return Precedence(base=None)
        base = v.get("base")
        if base not in (None, INVALID):
            self.check_part_ref(base, ("precedence", "base"))
        rules: list[PrecedenceRule] = []
        graph: nx.DiGraph[str] = nx.DiGraph()
        for i, r in enumerate(v.get("rules") or []):
            path: PathKey = ("precedence", "rules", i)
            ok = self.check_part_ref(r["before"], (*path, "before"))
            ok = self.check_part_ref(r["after"], (*path, "after")) and ok
            if ok and r["before"] == r["after"]:
                self.err((*path, "after"), "expected two different parts, found "
                         f'"{r["after"]}" before itself')
                ok = False
            if ok:
                line = self.doc.where(path)[0]
                rules.append(PrecedenceRule(r["before"], r["after"], r["reason"], line))
                graph.add_edge(r["before"], r["after"], index=i, line=line)
        groups: list[AssemblyGroup] = []
        for i, g in enumerate(v.get("groups") or []):
            ok = all([self.check_part_ref(p, ("precedence", "groups", i, "parts", j))
                      for j, p in enumerate(g["parts"])])
            if ok:
                groups.append(AssemblyGroup(tuple(g["parts"]), g["reason"]))
        try:
            cycle = nx.find_cycle(graph)
        except nx.NetworkXNoCycle:
            cycle = None
        if cycle:
            names = " -> ".join([cycle[0][0], *(e[1] for e in cycle)])
            lines = ", ".join(str(graph.edges[e]["line"]) for e in cycle)
            first = min(graph.edges[e]["index"] for e in cycle)
            self.err(("precedence", "rules", first), f"precedence rules form a cycle: {names} "
                     f"(rules on lines {lines}); expected an order that can be met")
        return Precedence(base=base if base is not INVALID else None, rules=tuple(rules),
                          groups=tuple(groups))


def iso286_normal(designation: str) -> str:
    """Normalise ``"H7-g6"``/``"H7 g6"`` to ``"H7/g6"``."""
    for sep in ("-", " "):
        designation = designation.replace(sep, "/")
    return designation
