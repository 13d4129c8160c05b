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


TIME_PLOT_MARGINS = {"left": 0.08, "right": 0.97, "bottom": 0.14, "top": 0.84}
"""Fixed margins (figure fractions) of the per-step time plots (7.5 x 3.2 in): room for the
y label, the x label, the title and the phase names above the axes. Fixed instead of
``tight_layout``, which lays the text out once more per figure (about a third of a plot's
cost, measured: 5 x (clamp + insertion plot) 1.14 -> 0.70 s CPU)."""


def _save(fig, path: str | Path, margins: dict[str, float] | None = None) -> Path:
    """PNG of ``fig`` at ``path``; with ``margins`` (``subplots_adjust`` arguments) instead of
    a tight layout. A twin y axis on the right gets the same room as the left one."""
    buf = io.BytesIO()
    if margins is None:
        fig.tight_layout()
    else:
        m = dict(margins)
        if len(fig.axes) > 1:
            m["right"] = 1.0 - m["left"]
        fig.subplots_adjust(**m)
    fig.savefig(buf, format="png", metadata={"Software": None})
    return atomic_write_bytes(path, buf.getvalue())


def _phase_bands(ax, record: StepRecord) -> None:
    """Shade each phase span and label every one at the top of the axes (names of narrow
    spans are written vertically inside the axes so that none is left out)."""
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
        if (t1 - t0) / total >= 0.06:
            ax.text(0.5 * (t0 + t1), 1.0, name, transform=ax.get_xaxis_transform(), ha="center",
                    va="bottom", fontsize=7, color="#555555")
        else:  # too narrow for a horizontal name: write it vertically inside the band
            ax.text(0.5 * (t0 + t1), 0.97, name, transform=ax.get_xaxis_transform(),
                    ha="center", va="top", rotation=90, fontsize=6.5, color="#555555")


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
        ax.set_title(title, fontsize=9, pad=14, y=1.0)  # fixed: see TIME_PLOT_MARGINS
    return _save(fig, path, TIME_PLOT_MARGINS)


def meaningful_depth_mm(record: StepRecord, target_depth_m: float, near_m: float = 5e-3
                        ) -> np.ndarray:
    """Insertion depth per tick, mm, NaN where it is not a depth: before the part, lowered
    towards the hole, first comes within ``near_m`` of the mouth (on the tray, lifted and
    carried, the distance to the target along the mate axis is a distance, not a depth)."""
    depth_mm = (target_depth_m - record.axial_error_m) * 1e3
    late = np.isin(record.phase_index, [i for i, n in enumerate(record.phase_names)
                                        if n in ("lower", "insert", "release", "retreat")])
    near = late & (depth_mm >= -near_m * 1e3) & (depth_mm <= (target_depth_m + near_m) * 1e3)
    if near.any():
        first = int(np.flatnonzero(near)[0])
        near[first:] = late[first:]
    return np.where(near, depth_mm, np.nan)


def insertion_plot(record: StepRecord, path: str | Path, *, target_depth_m: float,
                   title: str = "", near_m: float = 5e-3) -> Path:
    """Insertion depth (mm) and contact force on the part (N) over time, on twin axes.

    Depth is drawn only where it means something: from the moment the part is within
    ``near_m`` of the hole's mouth (depth >= -near_m) during "lower"/"insert" and after; while
    the part is on the tray or carried, the distance to the target along the mate axis is not
    a depth and is left out (the path picture shows where the part is then).
    """
    fig, ax = _figure()
    _phase_bands(ax, record)
    force = np.linalg.norm(record.external_force_N, axis=1)
    shown = meaningful_depth_mm(record, target_depth_m, near_m)
    ax.plot(record.t_s, shown, color="#2ca02c", lw=1.5,
            label=f"insertion depth (shown from {near_m * 1e3:g} mm above the mouth)")
    ax.axhline(target_depth_m * 1e3, color="#2ca02c", ls=":", lw=1.0,
               label=f"seated ({target_depth_m * 1e3:.1f} mm)")
    ax.axhline(0.0, color="#888888", ls="-", lw=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("insertion depth [mm]", color="#2ca02c")
    ax.set_ylim(-near_m * 1e3 - 0.5, target_depth_m * 1e3 * 1.15 + 0.5)
    ax2 = ax.twinx()
    ax2.plot(record.t_s, force, color="#9467bd", lw=0.9, label="contact force")
    ax2.set_ylabel("contact force on part [N]", color="#9467bd")
    ax.set_xlim(record.t_s[0], record.t_s[-1])
    lines = ax.get_lines() + ax2.get_lines()
    lines = [ln for ln in lines if not ln.get_label().startswith("_")]
    ax.legend(lines, [ln.get_label() for ln in lines], loc="center left", fontsize=7,
              framealpha=0.9)
    if title:
        ax.set_title(title, fontsize=9, pad=14, y=1.0)  # fixed: see TIME_PLOT_MARGINS
    return _save(fig, path, TIME_PLOT_MARGINS)


def precedence_graph_plot(graph: Any, path: str | Path, *, order: Sequence[str] = ()) -> Path:
    """The precedence graph drawn in layers (a part below every part it must follow), each
    edge coloured by its origin (declared, geometry, stability, base); implied edges (those
    that follow from others) are left out of the drawing, not out of the table.

    Parameters
    ----------
    graph : networkx.DiGraph
        Nodes are parts; an edge ``u -> v`` (``u`` before ``v``) carries ``origins``, a list
        of dicts with ``kind`` and ``reason``.
    order : the planned order, to place parts of one layer left to right.
    """
    import networkx as nx

    colors = {"declared": "#1f77b4", "rule": "#1f77b4", "geometry": "#d62728",
              "stability": "#2ca02c", "base": "#7f7f7f", "mate": "#9467bd"}
    fig, ax = _figure(7.5, 3.4)
    ax.axis("off")
    g: nx.DiGraph[str] = nx.DiGraph(graph)
    rank = {n: i for i, n in enumerate(order)}
    layers = list(nx.topological_generations(g)) if nx.is_directed_acyclic_graph(g) else [list(g)]
    pos = {}
    for y, layer in enumerate(layers):
        layer = sorted(layer, key=lambda n: (rank.get(n, 1 << 30), str(n)))
        for x, n in enumerate(layer):
            pos[n] = (x - (len(layer) - 1) / 2.0, -float(y))
    drawn = nx.transitive_reduction(g) if nx.is_directed_acyclic_graph(g) else g
    used: set[str] = set()
    for u, v in drawn.edges():
        kinds = sorted({o.get("kind", "?") for o in g.edges[u, v].get("origins", [])}
                       - ({"base"} if len(g.edges[u, v].get("origins", [])) > 1 else set()))
        kind = kinds[0] if kinds else "base"
        used.update(kinds)
        ax.annotate("", xy=pos[v], xytext=pos[u],
                    arrowprops={"arrowstyle": "-|>", "color": colors.get(kind, "#444444"),
                                "lw": 1.4, "shrinkA": 16, "shrinkB": 16})
        mx, my = 0.5 * (pos[u][0] + pos[v][0]), 0.5 * (pos[u][1] + pos[v][1])
        ax.text(mx, my, ", ".join(kinds), fontsize=6.5, ha="center", va="center",
                color=colors.get(kind, "#444444"),
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85})
    for n, (px, py) in pos.items():
        ax.text(px, py, str(n), ha="center", va="center", fontsize=8.5,
                bbox={"boxstyle": "round,pad=0.35", "fc": "#f5f5f5", "ec": "#555555"})
    xs = [p[0] for p in pos.values()] or [0.0]
    ys = [p[1] for p in pos.values()] or [0.0]
    ax.set_xlim(min(xs) - 0.8, max(xs) + 0.8)
    ax.set_ylim(min(ys) - 0.5, max(ys) + 0.5)
    ax.set_title("precedence: an arrow points from a part to one that must come after it "
                 "(implied arrows omitted)", fontsize=8)
    return _save(fig, path)


_UNITS = {"pose_lateral_m": (1e3, "mm"), "pose_angular_rad": (180.0 / math.pi, "deg")}


def factor_unit(factor: str) -> tuple[float, str]:
    """Display scale and unit of a swept factor (clearances in µm, robot error in mm,
    angles in degrees)."""
    if factor.startswith("clearance["):
        return 1e6, "µm"
    return _UNITS.get(factor, (1.0, ""))


_LABELS = {"pose_lateral_m": "lateral robot error", "pose_angular_rad": "robot tilt error"}


def factor_label(factor: str) -> str:
    """A swept factor's name for people: ``clearance[m21a]`` -> ``clearance m21a``,
    ``pose_angular_rad`` -> ``robot tilt error`` (units go beside it, not in the name)."""
    if factor in _LABELS:
        return _LABELS[factor]
    if "[" in factor and factor.endswith("]"):
        head, _, rest = factor.partition("[")
        return f"{head} {rest[:-1]}"
    return factor


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
        label = factor_label(e.factor)
        ax.set_title(f"{label}{r}", fontsize=9)
        ax.set_xlabel(f"{label} [{unit}]" if unit else label, fontsize=8)
        ax.set_ylabel("success rate", fontsize=8)
        ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
    fig.suptitle(f"{step.label}: {step.successes}/{step.n} succeeded "
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
