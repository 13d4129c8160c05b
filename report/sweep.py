"""The sweep report: per step the success rate with its interval, what drives failures, and
the success-vs-factor plots. It only renders: the statistics, the driver selection and its
q-values are :func:`asmplan.sim.sweep.summarize`'s."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import jinja2

from .. import __version__
from ..fileio import atomic_write_text
from ..knowledge.model import Product
from .plots import factor_label, factor_unit, sweep_step_plot


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
                        step_mates: dict[str, tuple[str, ...]],
                        step_numbers: dict[str, int] | None = None) -> list[str]:
    """One warning per swept step whose mates were sampled below the preset's smallest
    resolvable diametral clearance (what fraction, and the declared range), naming each mate.
    Steps are named ``step N (part)`` with ``step_numbers`` (from 1), else by their part."""
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
            label = (f"step {step}" if step_numbers is None or step not in step_numbers
                     else f"step {step_numbers[step]} ({step})")
            out.append(f"{label}: sampled clearances below what the {fidelity.name} preset "
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


def driver_text(st: Any) -> str:
    """The named driver of a :class:`~asmplan.sim.sweep.StepSummary` with its correlation, p,
    q and the factor value of 50 % success; "" when none is named."""
    if st.driver is None:
        return ""
    e = next(e for e in st.effects if e.factor == st.driver)
    scale, unit = factor_unit(e.factor)
    x50 = "" if not math.isfinite(e.x50) else f"; 50 % success at {e.x50 * scale:.3g} {unit}".rstrip()
    return (f"{factor_label(e.factor)} (correlation {e.correlation:+.2f}, p = {e.p_value:.2g}, "
            f"Benjamini-Hochberg q = {e.q_value:.2g}{x50})")


def no_driver_text(st: Any, drivers: Any) -> str:
    """Why no factor is named for a step (:attr:`StepSummary.driver_status`), in words, with
    the rule of :class:`~asmplan.sim.sweep.DriverSettings` it did not meet."""
    tested = [e for e in st.effects if math.isfinite(e.q_value)]
    if st.driver_status == "no_failures":
        return ("every sample succeeded" if st.successes == st.n else
                "every sample failed: nothing to contrast the failures with")
    if st.driver_status == "too_few_samples":
        return (f"too few samples (needs >= {drivers.min_samples} with >= "
                f"{drivers.min_each_outcome} successes and {drivers.min_each_outcome} failures; "
                f"has {st.n} with {st.successes} and {st.n - st.successes})")
    if st.driver_status == "nothing_tested":
        return "no factor of this step's scene varied"
    best = min(tested, key=lambda e: e.q_value, default=None)
    return (f"none of the {len(tested)} factors tested has q < {drivers.fdr_alpha:g}"
            + ("" if best is None else f" (lowest: {factor_label(best.factor)}, q = {best.q_value:.2g})"))


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
                       warnings: list[str] | None = None) -> Path:
    """Write ``sweep-<step>.png`` per swept step and ``sweep-report.html`` into ``folder``.

    ``summary`` is a :class:`~asmplan.sim.sweep.SweepSummary` (its drivers already chosen);
    ``captures`` the lateral error each step's mates should absorb (clearance/2 + chamfer, m)
    to mark on the plots; ``warnings`` are shown above the results.
    """
    folder = Path(folder)
    steps = []
    for st in summary.steps:
        image = f"sweep-{st.step}.png"
        sweep_step_plot(st, captures.get(st.step), folder / image)
        capture = captures.get(st.step)
        steps.append({
            "name": st.label,
            "n": st.n, "successes": st.successes,
            "rate": f"{100 * st.rate:.1f} %", "ci": f"{100 * st.ci_low:.1f} - {100 * st.ci_high:.1f} %",
            "driver": driver_text(st) or "none named: " + no_driver_text(st, summary.drivers),
            "tested": [(factor_label(e.factor), f"{e.correlation:+.2f}", f"{e.p_value:.2g}",
                        f"{e.q_value:.2g}") for e in st.effects if math.isfinite(e.q_value)],
            "image": image,
            "reasons": [(failure_text(f), f.count) for f in st.failures[:8]],
            "capture": "" if capture is None else f"{capture * 1e3:.3g} mm"})
    env = jinja2.Environment(loader=jinja2.PackageLoader("asmplan.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    html = env.get_template("sweep.html.j2").render(
        product=product, spec=spec, settings=spec_rows(spec), warnings=warnings or [],
        fidelity=fidelity, steps=steps, n_samples=n_samples, method=summary.drivers.method,
        errors=[(error_text(code), n) for code, n in summary.errors], version=__version__)
    return atomic_write_text(folder / "sweep-report.html", html)
