"""The sweep report: per step the success rate with its interval, what drives failures, and
the success-vs-factor plots (the sweep's results are read from its summary only)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import jinja2

from .. import __version__
from ..fileio import atomic_write_text
from ..knowledge.model import Product
from .plots import factor_label, factor_unit, sweep_step_plot

MIN_SAMPLES_FOR_DRIVER = 10
"""A factor is named as driving a step's failures only with at least this many samples..."""
MIN_EACH_OUTCOME = 2
"""...and at least this many successes and this many failures among them."""
FDR_ALPHA = 0.05
"""False discovery rate (Benjamini-Hochberg) at which a factor is named as driving."""


def step_factors(plan: Any, product: Product, k: int) -> set[str]:
    """Factors that can touch step ``k``'s scene: the clearance of every mate between parts
    already placed or held (parts placed later are not in the scene), the friction of those
    parts, and the robot's pose error."""
    present = {s.part for s in plan.steps[:k + 1]}
    out = {"pose_lateral_m", "pose_angular_rad"}
    out |= {f"friction[{p}]" for p in present}
    out |= {f"clearance[{m.name}]" for m in product.mates
            if m.pin_part in present and m.hole_part in present}
    return out


def named_drivers(summary: Any, factors: dict[str, set[str]]) -> tuple[Any, dict[str, dict[str, float]]]:
    """The summary with each step's factors limited to those that touch its scene and its
    driver chosen after a multiple-testing correction; and the adjusted p-values (q).

    Method: for each step, only the factors in ``factors[step]`` are tested; their
    correlation p-values are adjusted with Benjamini-Hochberg
    (:func:`scipy.stats.false_discovery_control`); a factor is named as driving when its q is
    below :data:`FDR_ALPHA` (the largest absolute correlation among those), and only when the
    step has at least :data:`MIN_SAMPLES_FOR_DRIVER` samples with at least
    :data:`MIN_EACH_OUTCOME` successes and failures each. Otherwise no factor is named.
    """
    from dataclasses import replace

    from scipy.stats import false_discovery_control

    steps = []
    qs: dict[str, dict[str, float]] = {}
    for st in summary.steps:
        allowed = factors.get(st.step)
        effects = tuple(e for e in st.effects if allowed is None or e.factor in allowed)
        tested = [e for e in effects if math.isfinite(e.p_value)]
        q = (false_discovery_control([e.p_value for e in tested], method="bh")
             if tested else [])
        qs[st.step] = {e.factor: float(v) for e, v in zip(tested, q, strict=True)}
        enough = (st.n >= MIN_SAMPLES_FOR_DRIVER
                  and min(st.successes, st.n - st.successes) >= MIN_EACH_OUTCOME)
        significant = [e for e in tested if qs[st.step][e.factor] < FDR_ALPHA] if enough else []
        driver = max(significant, key=lambda e: abs(e.correlation)).factor if significant else None
        steps.append(replace(st, effects=effects, driver=driver))
    return replace(summary, steps=tuple(steps)), qs


def spec_rows(spec: dict[str, Any]) -> list[tuple[str, str]]:
    """The sweep settings in the units people read (mm, µm, deg), not raw SI."""
    out = []
    for k, v in sorted(spec.items()):
        if k.endswith("_rad") and isinstance(v, int | float):
            out.append((k.removesuffix("_rad"), f"{math.degrees(v):.3g} deg"))
        elif k.endswith("_m") and isinstance(v, int | float):
            out.append((k.removesuffix("_m"), f"{v * 1e3:.3g} mm"))
        elif isinstance(v, list | tuple):
            out.append((k, ", ".join(map(str, v)) or "nothing"))
        else:
            out.append((k, str(v)))
    return out


def resolution_warnings(product: Product, fidelity: Any, samples: list[Any],
                        step_mates: dict[str, tuple[str, ...]]) -> list[str]:
    """One warning per swept step whose mates were sampled below the preset's smallest
    resolvable diametral clearance (what fraction, and the declared range), naming each mate."""
    res = fidelity.min_resolvable_clearance_m
    out = []
    for step, mates in step_mates.items():
        parts = []
        for m in product.mates:
            if m.name not in mates:
                continue
            xs = [x for x in (s.clearance_m.get(m.name) for s in samples) if x is not None]
            fit = (f"{m.name} ({m.fit or 'explicit'}, {m.clearance_min_m * 1e6:.0f} to "
                   f"{m.clearance_max_m * 1e6:.0f} µm)")
            below = sum(x < res for x in xs)
            if below:
                parts.append(f"{fit}: {below} of {len(xs)} samples")
            elif not xs and m.clearance_min_m < res:
                parts.append(f"{fit}: not varied, its smallest clearance is below")
        if parts:
            out.append(f"step {step}: sampled clearances below what the {fidelity.name} preset "
                       f"resolves ({res * 1e6:.0f} µm): {'; '.join(parts)}. There the simulation "
                       "does not resolve the fit's capture boundary, rim stops or jams: its rate "
                       "says how the preset treats the part, not how the real fit behaves.")
    return out

CRITERIA = {
    # code: (words, display scale, unit) -- the criteria of asmplan.sim.results.criteria_table
    "position": ("final position error", 1e3, "mm"),
    "angle": ("final angle error", 180 / math.pi, "deg"),
    "insertion_depth": ("insertion depth not reached, short by", 1e3, "mm"),
    "slip": ("slip in the fingers", 1e3, "mm"),
    "rotational_slip": ("rotational slip in the fingers", 180 / math.pi, "deg"),
    "drop": ("part dropped", 1.0, ""),
    "insertion_force": ("peak insertion force", 1.0, "N"),
    "penetration": ("contact penetration (the solver did not resolve a contact)", 1e3, "mm"),
    "nan": ("NaN in the simulation state", 1.0, ""),
    "energy": ("energy growth the motion and free fall cannot explain", 1.0, ""),
}
ERRORS = {
    "worker_died": "the worker process kept dying on this sample",
    "not_json_safe": "the task returned a value that is not JSON-safe",
    "unknown": "no reason recorded",
}


def failure_text(f: Any) -> str:
    """One line for a :class:`~asmplan.sim.sweep.FailureCount`: the criterion in words, the
    range of measured values and the limit."""
    words, scale, unit = CRITERIA.get(f.criterion, (f.criterion.replace("_", " "), 1.0, ""))
    if f.value_min is None:
        return words
    lo, hi = f.value_min * scale, f.value_max * scale
    values = f"{lo:.3g} {unit}" if lo == hi else f"{lo:.3g}-{hi:.3g} {unit}"
    limit = "" if f.limit is None else f" > limit {f.limit * scale:.3g} {unit}"
    return f"{words}: {values.strip()}{limit}".rstrip()


def error_text(code: str) -> str:
    """Words for a :attr:`~asmplan.sim.sweep.TaskResult.error_code`."""
    if code.startswith("raised:"):
        return f"the task raised {code.split(':', 1)[1]}"
    return ERRORS.get(code, code)


def write_sweep_report(folder: Path, product: Product, summary: Any, spec: dict[str, Any],
                       fidelity: str, captures: dict[str, float | None], *, n_samples: int,
                       warnings: list[str] | None = None,
                       q_values: dict[str, dict[str, float]] | None = None) -> Path:
    """Write ``sweep-<step>.png`` per swept step and ``sweep-report.html`` into ``folder``.

    ``summary`` is a :class:`~asmplan.sim.sweep.SweepSummary`; ``captures`` the lateral error
    each step's mates should absorb (clearance/2 + chamfer, m) to mark on the plots;
    ``warnings`` are shown above the results; ``q_values`` (step -> factor -> q) are the
    Benjamini-Hochberg adjusted p-values of :func:`named_drivers`, shown beside p.
    """
    folder = Path(folder)
    steps = []
    for st in summary.steps:
        image = f"sweep-{st.step}.png"
        sweep_step_plot(st, captures.get(st.step), folder / image)
        driver = ""
        if st.driver is not None:
            e = next(e for e in st.effects if e.factor == st.driver)
            scale, unit = factor_unit(e.factor)
            x50 = ("" if not math.isfinite(e.x50) else
                   f"; 50 % success at {e.x50 * scale:.3g} {unit}".rstrip())
            q = (q_values or {}).get(st.step, {}).get(e.factor)
            adjusted = "" if q is None else f", Benjamini-Hochberg q = {q:.2g}"
            driver = (f"{factor_label(e.factor)} (correlation {e.correlation:+.2f}, "
                      f"p = {e.p_value:.2g}{adjusted}{x50})")
        capture = captures.get(st.step)
        steps.append({
            "name": st.step, "n": st.n, "successes": st.successes,
            "rate": f"{100 * st.rate:.1f} %", "ci": f"{100 * st.ci_low:.1f} - {100 * st.ci_high:.1f} %",
            "driver": driver or "none found", "image": image,
            "reasons": [(failure_text(f), f.count) for f in st.failures[:8]],
            "capture": "" if capture is None else f"{capture * 1e3:.3g} mm"})
    env = jinja2.Environment(loader=jinja2.PackageLoader("asmplan.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    html = env.get_template("sweep.html.j2").render(
        product=product, spec=spec, settings=spec_rows(spec), warnings=warnings or [],
        fidelity=fidelity, steps=steps, n_samples=n_samples,
        errors=[(error_text(code), n) for code, n in summary.errors], version=__version__)
    return atomic_write_text(folder / "sweep-report.html", html)
