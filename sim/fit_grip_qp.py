"""A held part's fit contact and its pads' friction solved as one problem (floating jaws).

Why
---
:class:`~asmplan.sim.feature_contact.HeldFitContact` solves the fit's rows after Bullet's step.
The pads' friction joins that solve as friction rows (what each point's cone has left after
Bullet's step), alternated with the exact normal solve in 3 rounds. Against a partner that
cannot move, with the robot driving the gripper into it, the fit's rows and the pads'
sticking have no common solution: the grip must yield, and the impulse at which it yields is
the pads' capacity. The alternation does not get there: on the pneumatic front cap's second
contact step (dumped solve) its fit force is 0.21 / 0.52 / 1.39 / 4.46 / 11.5 N after
3 / 10 / 30 / 100 / 1,000 rounds, so with 3 rounds a held part turns in its grip under a
contact force far below what the grip holds: the 10 mm pin held 5 deg off its hole's axis by
floating jaws turned at 0.2 rad/s relative to the gripper from its first touch at 0.08 N
(tests/sim/test_exact_contact.py), against a pad torsion of ~0.02-0.05 N m.

What
----
The impulses p (fit normals >= 0, the fit's friction and the pads' friction each in a box)
minimise 1/2 p^T A p + p^T b, A = J M^-1 J^T, b = J u - target, whose optimality conditions
are the contact conditions: a fit row with impulse is closed at its gap (J u' = -g / dt), one
without is open (>=); a pad or fit friction pair inside its box sticks (to the gripper's
velocity at the pad, to the partner's at the fit), one on its bound slides against it. Solved
exactly by bounded-variable least squares (``scipy.optimize.lsq_linear``, BVLS) on the
Cholesky factor of A + eps I (eps = 1e-6 of A's mean diagonal: a compliance that changes a
row's velocity by eps p, 4e-7 m/s at the front cap's 8.5 N; at 1e-9 BVLS returned velocities
of metres per second). Coulomb's disc is replaced by the square inscribed in it (each tangent
impulse within cap / sqrt 2: the grip yields at 71-100 % of its Coulomb capacity, depending on
the direction). The fit's friction bound mu lambda is taken from the previous pass
(:data:`PASSES`). Measured on the front cap's dumped step: the velocity of 1,000 alternation
rounds (relative turn (-0.0795, -0.3537, 0.0102) rad/s against (-0.0796, -0.3538, 0.0102)),
fit force 8.5 N, 0.6-0.9 ms a solve.
"""

from __future__ import annotations

import math

import numpy as np

PASSES = 3
"""Solves per step: the fit's friction bound mu lambda from the previous pass's lambda."""

REGULARISATION = 1e-6
"""eps / mean diagonal of A (module docstring)."""


def solve_fit_with_pad_friction(
    Jn: np.ndarray, gap_m: np.ndarray, Jt: np.ndarray, mu: np.ndarray, touching: np.ndarray,
    P: np.ndarray, v_pad: np.ndarray, pad_cap: np.ndarray, u: np.ndarray, Minv_sqrt: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The held body's velocity with its fit contact and its pads' friction (module docstring).

    Parameters
    ----------
    Jn : (k, 6) float array
        The fit's normal rows (pushing the body) on its twist about its centre of mass.
    gap_m : (k,) float array
        Their gaps before the step, m.
    Jt : (k, 2, 6) float array
        The fit's tangent rows.
    mu : (k,) float array
        The fit's Coulomb coefficients; friction only where ``touching`` (k,) bool.
    P : (kp, 2, 6) float array
        The pads' tangent rows; ``v_pad`` (kp, 2) the gripper's velocity along them, m/s;
        ``pad_cap`` (kp,) each point's friction impulse bound, N s.
    u : (6,) float array
        The body's twist after Bullet's step.
    Minv_sqrt : (6, 6) float array
    dt : float

    Returns
    -------
    (u' (6,), fit normal impulses (k,), fit tangent impulses (k, 2)), N s.
    """
    from scipy.optimize import lsq_linear

    k, kp = Jn.shape[0], P.shape[0]
    J = np.vstack([Jn, Jt[:, 0], Jt[:, 1], P.reshape(2 * kp, 6)])
    target = np.concatenate([-gap_m / dt, np.zeros(2 * k), v_pad.reshape(-1)])
    G = J @ Minv_sqrt
    m = J.shape[0]
    A = G @ G.T
    A[np.diag_indices(m)] += REGULARISATION * float(np.trace(A)) / m
    L = np.linalg.cholesky(A)  # A = L L^T: 1/2 |L^T p + L^-1 b|^2 = 1/2 p^T A p + p^T b + c
    d = -np.linalg.solve(L, J @ u - target)
    C = L.T
    pad_bound = np.repeat(pad_cap / math.sqrt(2.0), 2)
    lam = np.zeros(k)
    p = np.zeros(m)
    for _ in range(PASSES):
        fit_bound = np.tile(mu * lam * touching / math.sqrt(2.0), 2)
        ub = np.concatenate([np.full(k, np.inf), fit_bound, pad_bound])
        lb = np.concatenate([np.zeros(k), -fit_bound, -pad_bound])
        free = ub > lb  # a zero box is an impulse held at 0
        p = np.zeros(m)
        p[free] = lsq_linear(C[:, free], d, bounds=(lb[free], ub[free]), method="bvls",
                             tol=1e-12).x
        lam = p[:k]
    Minv = Minv_sqrt @ Minv_sqrt
    u_new = u + Minv @ (J.T @ p)
    return u_new, lam, np.column_stack([p[k:2 * k], p[2 * k:3 * k]])


__all__ = ["PASSES", "REGULARISATION", "solve_fit_with_pad_friction"]
