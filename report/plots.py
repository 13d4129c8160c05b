"""Force, depth and contact plots of simulated steps (matplotlib, Agg backend, no display).

Each function draws one figure from a :class:`~asmplan.sim.records.StepRecord` and writes it
as a PNG atomically; the bytes are deterministic for the same record.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import atomic_write_bytes
from ..sim.records import StepRecord

PHASE_COLORS = {
    "approach": "#f2f2f2", "clamp": "#fde0c5", "hold": "#e6f0d8", "lift": "#d7e8f5",
    "translate": "#ece2f4", "lower": "#fbe3ea", "insert": "#fbe3ea", "release": "#e8e8e8",
    "retreat": "#f2f2f2",
}


def _figure(width_in: float = 7.5, height_in: float = 3.2):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=110)
    return fig, fig.add_subplot(1, 1, 1)


def _save(fig, path: str | Path) -> Path:
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return atomic_write_bytes(path, buf.getvalue())


def _phase_bands(ax, record: StepRecord) -> None:
    """Shade each phase span and label it at the top of the axes."""
    t = record.t_s
    if t.size == 0:
        return
    idx = record.phase_index
    starts = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    ends = np.r_[starts[1:], idx.size]
    total = max(float(t[-1] - t[0]), 1e-9)
    for s, e in zip(starts, ends, strict=True):
        name = record.phase_names[idx[s]]
        t0 = t[s]
        t1 = t[e] if e < idx.size else t[-1]
        ax.axvspan(t0, t1, color=PHASE_COLORS.get(name, "#f4f4f4"), zorder=0, lw=0)
        if (t1 - t0) / total >= 0.06:  # label only spans wide enough to hold the name
            ax.text(0.5 * (t0 + t1), 1.0, name, transform=ax.get_xaxis_transform(), ha="center",
                    va="bottom", fontsize=7, color="#555555")


def clamp_force_plot(record: StepRecord, path: str | Path, *, title: str = "",
                     reference: Sequence[tuple[float, float]] | None = None,
                     slip_threshold_N: float | None = None, grip_limit_N: float | None = None) -> Path:
    """Commanded vs simulated clamp force per finger over the cycle (the seed's Fig. 7).

    Parameters
    ----------
    reference : optional (t_s, force_N) points of a measured curve to overlay.
    slip_threshold_N : the analytic slip limit m(g+a)/(2 mu), drawn as a dashed line.
    grip_limit_N : the gripper's force limit, drawn as a dotted line.
    """
    fig, ax = _figure()
    _phase_bands(ax, record)
    measured = np.nanmean(record.measured_force_N, axis=1)
    ax.plot(record.t_s, record.commanded_force_N, color="#1f4e99", lw=1.6, label="commanded")
    ax.plot(record.t_s, measured, color="#d62728", lw=1.0, label="simulated (mean of fingers)")
    if reference is not None:
        rt, rf = zip(*reference, strict=True)
        ax.plot(rt, rf, "k.", ms=4, label="seed paper")
    if slip_threshold_N is not None:
        ax.axhline(slip_threshold_N, color="#ff7f0e", ls="--", lw=1.0,
                   label=f"slip limit {slip_threshold_N:.2f} N")
    top = np.nanmax([np.nanmax(record.commanded_force_N, initial=0.0), np.nanmax(measured, initial=0.0),
                     slip_threshold_N or 0.0])
    if grip_limit_N is not None:
        if grip_limit_N <= 1.5 * top:
            top = max(top, grip_limit_N)
            ax.axhline(grip_limit_N, color="#444444", ls=":", lw=1.0,
                       label=f"grip limit {grip_limit_N:.0f} N")
        else:  # far above: say it rather than squash the curves
            ax.plot([], [], " ", label=f"grip limit {grip_limit_N:.0f} N (off scale)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("clamp force per finger [N]")
    ax.set_ylim(0.0, max(top * 1.25, 0.1))
    ax.set_xlim(record.t_s[0], record.t_s[-1])
    ax.legend(loc="lower center", fontsize=7, ncol=2, framealpha=0.9)
    if title:
        ax.set_title(title, fontsize=9, pad=14)
    return _save(fig, path)


def insertion_plot(record: StepRecord, path: str | Path, *, target_depth_m: float,
                   title: str = "") -> Path:
    """Insertion depth (mm) and contact force on the part (N) over time, on twin axes."""
    fig, ax = _figure()
    _phase_bands(ax, record)
    depth_mm = (target_depth_m - record.axial_error_m) * 1e3
    force = np.linalg.norm(record.external_force_N, axis=1)
    ax.plot(record.t_s, depth_mm, color="#2ca02c", lw=1.5, label="insertion depth")
    ax.axhline(target_depth_m * 1e3, color="#2ca02c", ls=":", lw=1.0, label="seated")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("insertion depth [mm]", color="#2ca02c")
    ax2 = ax.twinx()
    ax2.plot(record.t_s, force, color="#9467bd", lw=0.9, label="contact force")
    ax2.set_ylabel("contact force on part [N]", color="#9467bd")
    ax.set_xlim(record.t_s[0], record.t_s[-1])
    lines = ax.get_lines() + ax2.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], loc="upper left", fontsize=7, framealpha=0.9)
    if title:
        ax.set_title(title, fontsize=9, pad=14)
    return _save(fig, path)


_UNITS = {"pose_lateral_m": (1e3, "mm"), "pose_angular_rad": (180.0 / math.pi, "deg")}


def factor_unit(factor: str) -> tuple[float, str]:
    """Display scale and unit of a swept factor (lengths in mm, angles in degrees)."""
    if factor.startswith("clearance["):
        return 1e3, "mm"
    return _UNITS.get(factor, (1.0, ""))


def sweep_step_plot(step: Any, capture_m: float | None, path: str | Path) -> Path:
    """Success rate (Wilson 95 % bars) per bin of every varied factor of one swept step
    (a :class:`~asmplan.sim.sweep.StepSummary`); ``capture_m`` marks clearance/2 + chamfer."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    effects = [e for e in step.effects if e.bins]
    n = max(1, len(effects))
    cols = min(3, n)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(4.2 * cols, 3.2 * rows), dpi=110)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax in axes.flat[len(effects):]:
        ax.axis("off")
    for ax, e in zip(axes.flat, effects, strict=False):
        scale, unit = factor_unit(e.factor)
        bins = [b for b in e.bins if b.n]
        x = [0.5 * (b.low + b.high) * scale for b in bins]
        y = [b.rate for b in bins]
        err = [[max(0.0, b.rate - b.ci_low) for b in bins],
               [max(0.0, b.ci_high - b.rate) for b in bins]]
        ax.errorbar(x, y, yerr=err, fmt="o-", capsize=3, color="tab:blue")
        if math.isfinite(e.x50):
            ax.axvline(e.x50 * scale, color="tab:red", ls=":",
                       label=f"x50 {e.x50 * scale:.3g} {unit}")
        if e.factor == "pose_lateral_m" and capture_m is not None:
            ax.axvline(capture_m * scale, color="k", ls="--",
                       label=f"clearance/2 + chamfer {capture_m * scale:.3g} {unit}")
        r = "" if not math.isfinite(e.correlation) else f" (r = {e.correlation:+.2f})"
        ax.set_title(f"{e.factor}{r}", fontsize=9)
        ax.set_xlabel(f"{e.factor} [{unit}]" if unit else e.factor, fontsize=8)
        ax.set_ylabel("success rate", fontsize=8)
        ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
    fig.suptitle(f"step {step.step}: {step.successes}/{step.n} succeeded "
                 f"({100 * step.rate:.1f} %, 95 % CI {100 * step.ci_low:.1f}-"
                 f"{100 * step.ci_high:.1f} %)",
                 fontsize=10)
    return _save(fig, path)


def reach_plot(product: Any, plan: Any, shoulder_world_m: np.ndarray, reach_m: float,
               path: str | Path) -> Path:
    """Top view of the cell: the table, the arm's base, the boundary of the flange's reach
    (its sphere about the shoulder cut at the table top and at the shoulder's height), the
    planned steps' part starts (circles, named) and every part's assembled pose (squares)."""
    fig, ax = _figure(6.5, 5.2)
    size = np.asarray(product.resources.table.size_m, float)
    ax.add_patch(_rect(-size[0] / 2, -size[1] / 2, size[0], size[1]))
    sx, sy, sz = (float(v) for v in shoulder_world_m)
    th = np.linspace(0, 2 * math.pi, 361)
    for z, style, label in ((0.0, "-", "reach at the table top"),
                            (sz, "--", f"reach at the shoulder's height ({sz * 1e3:.0f} mm)")):
        r2 = reach_m ** 2 - (sz - z) ** 2
        if r2 > 0:
            r = math.sqrt(r2)
            ax.plot(sx + r * np.cos(th), sy + r * np.sin(th), style, color="#3070b0", lw=1.2,
                    label=f"{label}: {r * 1e3:.0f} mm")
    ax.plot([sx], [sy], marker="o", ms=10, color="#3070b0", ls="none", label="arm base")
    for i, part in enumerate(product.parts):
        T_final = product.T_world_assembled(part.name)
        ax.plot([T_final[0, 3]], [T_final[1, 3]], marker="s", ms=6, color="#555555", ls="none",
                label="assembled poses" if i == 0 else None)
    if plan is not None:
        first = True
        for s in plan.steps:
            ax.plot([s.T_world_start[0, 3]], [s.T_world_start[1, 3]], marker="o", ms=6,
                    color="#e08020", ls="none", label="part starts" if first else None)
            ax.annotate(s.part, (s.T_world_start[0, 3], s.T_world_start[1, 3]), fontsize=7,
                        xytext=(3, 3), textcoords="offset points")
            first = False
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"reach of the arm: flange within {reach_m * 1e3:.0f} mm of the shoulder",
                 fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(True, lw=0.3)
    return _save(fig, path)


def _rect(x: float, y: float, w: float, h: float):
    from matplotlib.patches import Rectangle

    return Rectangle((x, y), w, h, facecolor="#eeeae2", edgecolor="#999999", lw=1.0)
