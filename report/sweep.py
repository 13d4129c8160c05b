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
            "driver": driver or "none found", "reasons": list(st.failure_reasons[:8]), "image": image,
            "capture": "" if capture is None else f"{capture * 1e3:.3g} mm"})
    env = jinja2.Environment(loader=jinja2.PackageLoader("asmplan.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    html = env.get_template("sweep.html.j2").render(
        product=product, spec=spec, fidelity=fidelity, steps=steps, n_samples=n_samples,
        errors=list(summary.errors), version=__version__)
    return atomic_write_text(folder / "sweep-report.html", html)
