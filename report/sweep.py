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
from .plots import factor_unit, sweep_step_plot

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
                       fidelity: str, captures: dict[str, float | None], *, n_samples: int) -> Path:
    """Write ``sweep-<step>.png`` per swept step and ``sweep-report.html`` into ``folder``.

    ``summary`` is a :class:`~asmplan.sim.sweep.SweepSummary`; ``captures`` the lateral error
    each step's mates should absorb (clearance/2 + chamfer, m) to mark on the plots.
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
            x50 = "" if not math.isfinite(e.x50) else f"; 50 % success at {e.x50 * scale:.3g} {unit}"
            driver = f"{e.factor} (correlation {e.correlation:+.2f}, p = {e.p_value:.2g}{x50})"
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
        product=product, spec=spec, fidelity=fidelity, steps=steps, n_samples=n_samples,
        errors=[(error_text(code), n) for code, n in summary.errors], version=__version__)
    return atomic_write_text(folder / "sweep-report.html", html)
