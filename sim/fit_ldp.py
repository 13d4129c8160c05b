"""The exact least-distance solve of the fit contact (:mod:`asmplan.sim.feature_contact`):
min |y| s.t. G y >= h, by Lawson and Hanson's reduction to non-negative least squares
(``scipy.optimize.nnls``)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["least_distance", "preload_solver"]


def preload_solver() -> None:
    """Import the solver of :func:`least_distance` now (scipy.optimize, 0.3-0.5 s of CPU):
    before forking simulator workers, which then inherit it instead of each importing it."""
    from scipy.optimize import nnls  # noqa: F401


_nnls: Any = None
"""``scipy.optimize.nnls``, imported by the first :func:`least_distance`."""


def least_distance(G: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """min |y| s.t. G y >= h (Lawson and Hanson, LDP via NNLS).

    Returns
    -------
    (y, lambda) or None
        The solution and the multipliers (y = G^T lambda, lambda >= 0); None when infeasible.
    """
    global _nnls
    if _nnls is None:  # here: a run without the fit contact imports no scipy
        from scipy.optimize import nnls

        _nnls = nnls
    k, n = G.shape
    # the array methods for np.all(h <= 0) and np.max(np.abs(h)): the same reductions (NaN
    # included) without numpy's ~3 us of dispatch each
    if k == 0 or h.max() <= 0.0:
        return np.zeros(n), np.zeros(k)
    scale = float(np.abs(h).max())
    E = np.vstack([G.T, (h / scale)[None, :]])
    f = np.zeros(n + 1)
    f[n] = 1.0
    u, _ = _nnls(E, f, maxiter=50 * (k + n))
    r = E @ u - f
    # infeasible: E u = f, to round-off (relative to E u's terms: an infeasible set of the
    # gearbox shaft's V pads and bores had |r| 2e-11 at |u| 3e4, and an absolute 1e-12 test on
    # r[n] took it for feasible, the impulses then 1e10 N s); a feasible one has |r| ~ 1
    if float(np.linalg.norm(r)) <= 1e-10 * (1.0 + float(np.abs(E).max()) * float(u.sum())):
        return None
    y = -r[:n] / r[n] * scale
    lam = -u / r[n] * scale
    return y, lam
