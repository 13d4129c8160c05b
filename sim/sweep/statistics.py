"""Statistics of a finished sweep: per step the success rate with its Wilson interval, failure
causes counted, and per varied factor the success rate in bins and a logistic fit.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

import numpy as np

from .journal import TaskResult
from .sampling import FACTORS, SampleParams

# ---------------------------------------------------------------------------------------------
# statistics


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, n : int
        0 <= successes <= n.
    confidence : float
        Two-sided confidence level in (0, 1).

    Returns
    -------
    (low, high) : tuple of float
        In [0, 1]; ``(0, 1)`` when ``n == 0``.
    """
    if not (0 <= successes <= n):
        raise ValueError(f"wilson_interval: expected 0 <= successes <= n, found {successes}, {n}")
    if n == 0:
        return (0.0, 1.0)
    from scipy.stats import binomtest

    ci = binomtest(successes, n).proportion_ci(confidence_level=confidence, method="wilson")
    low = 0.0 if successes == 0 else max(0.0, float(ci.low))  # exact ends (no rounding residue)
    high = 1.0 if successes == n else min(1.0, float(ci.high))
    return (low, high)


@dataclass(frozen=True)
class BinStat:
    """Success in one bin ``[low, high)`` of a factor (the last bin includes ``high``)."""

    low: float
    high: float
    n: int
    successes: int
    rate: float
    ci_low: float
    ci_high: float


@dataclass(frozen=True)
class FactorEffect:
    """How one factor relates to a step's success.

    Attributes
    ----------
    factor : str
        Factor key (see :meth:`SampleParams.factors`).
    n : int
    correlation : float
        Point-biserial correlation of success (1/0) with the factor; positive: larger values
        succeed more often. NaN when the factor or the outcome does not vary.
    p_value : float
        Two-sided p-value of that correlation (NaN with it).
    logistic_slope_per_sd : float
        Slope of a one-factor logistic fit, in log-odds per standard deviation of the factor
        (slightly ridge-penalised, so finite under perfect separation).
    x50 : float
        Factor value where the fit predicts 50 % success (NaN when outside the sampled range).
    bins : tuple of BinStat
        Equal-width bins over the sampled range.
    q_value : float
        ``p_value`` adjusted for testing all of the step's factors together (Benjamini-Hochberg,
        see :class:`DriverSettings`); NaN when the factor was not tested (``p_value`` NaN).
    """

    factor: str
    n: int
    correlation: float
    p_value: float
    logistic_slope_per_sd: float
    x50: float
    bins: tuple[BinStat, ...]
    q_value: float = math.nan


@dataclass(frozen=True)
class FailureCount:
    """How often one criterion failed in a step: its code (a criterion name of
    :func:`asmplan.sim.results.criteria_table`, or a task's own code), the count, and the
    range of the measured values with the limit (SI units; None for yes/no criteria or when the
    task gave none). English is written from this at the edges (CLI, report)."""

    criterion: str
    count: int
    value_min: float | None = None
    value_max: float | None = None
    limit: float | None = None


DriverStatus = Literal["named", "no_failures", "too_few_samples", "nothing_tested",
                       "none_significant"]
"""Why a step has (or has not) a named driver: one was named; the step never failed (or never
succeeded: nothing to contrast); fewer samples or outcomes than :class:`DriverSettings` asks;
no factor of its scene varied; no factor's q below the false discovery rate."""


@dataclass(frozen=True)
class DriverSettings:
    """How a factor is named as driving a step's failures.

    For each step only the factors that can touch its scene are tested (see
    :meth:`asmplan.sim.sweep.PlanSweep.scene_factors`); the p-values of their point-biserial
    correlations are adjusted together with the Benjamini-Hochberg procedure
    (:func:`scipy.stats.false_discovery_control`, ``method="bh"``), which bounds the expected
    share of wrongly named factors at ``fdr_alpha``. A factor is named when its q-value is below
    ``fdr_alpha`` (among several, the one with the largest absolute correlation), and only when
    the step has at least ``min_samples`` samples with at least ``min_each_outcome`` successes
    and as many failures.

    Attributes
    ----------
    min_samples : int
    min_each_outcome : int
    fdr_alpha : float
        False discovery rate, in (0, 1).
    """

    min_samples: int = 10
    min_each_outcome: int = 2
    fdr_alpha: float = 0.05

    def __post_init__(self) -> None:
        for name in ("min_samples", "min_each_outcome"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"DriverSettings.{name}: expected an integer >= 1, found {v!r}")
        if not 0.0 < float(self.fdr_alpha) < 1.0:
            raise ValueError(f"DriverSettings.fdr_alpha: expected a value in (0, 1), found "
                             f"{self.fdr_alpha!r}")

    @property
    def method(self) -> str:
        """The method in words (written into sweep.json and the report)."""
        return (f"point-biserial correlation per factor of the step's scene (scipy.stats.pearsonr), "
                f"p-values adjusted with Benjamini-Hochberg (scipy.stats.false_discovery_control); "
                f"named when q < {self.fdr_alpha:g}, with at least {self.min_samples} samples and "
                f"at least {self.min_each_outcome} successes and {self.min_each_outcome} failures")

    def to_dict(self) -> dict[str, Any]:
        return {"correction": "benjamini-hochberg", "fdr_alpha": self.fdr_alpha,
                "min_samples": self.min_samples, "min_each_outcome": self.min_each_outcome,
                "method": self.method}


@dataclass(frozen=True)
class StepSummary:
    """Success statistics of one step over the samples that evaluated it.

    ``step`` is the step's name (the part it moves, the key of the task's results); ``number``
    its plan step number counted from 1, as ``run`` and the report count (None when unknown).
    ``effects`` hold the factors tested for this step (those of its scene), each with its
    q-value; ``driver`` is the factor named as driving its failures (:class:`DriverSettings`)
    or None, and ``driver_status`` says why.
    """

    step: str
    n: int
    successes: int
    rate: float
    ci_low: float
    ci_high: float
    failures: tuple[FailureCount, ...]
    effects: tuple[FactorEffect, ...]
    driver: str | None
    driver_status: DriverStatus = "nothing_tested"
    number: int | None = None

    @property
    def label(self) -> str:
        """``"step 2 (part2)"``, or ``"step part2"`` without a number."""
        return f"step {self.step}" if self.number is None else f"step {self.number} ({self.step})"


@dataclass(frozen=True)
class SweepSummary:
    """Per-step statistics of a sweep plus the samples that produced no verdict.

    ``errors`` counts samples whose task raised or whose worker kept dying (``TaskResult.ok``
    False) by :attr:`TaskResult.error_code`; they are left out of every step's rate.
    """

    n_samples: int
    n_errors: int
    errors: tuple[tuple[str, int], ...]
    steps: tuple[StepSummary, ...]
    drivers: DriverSettings = DriverSettings()

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (NaN becomes None)."""

        def clean(o: Any) -> Any:
            if isinstance(o, float) and not math.isfinite(o):
                return None
            if isinstance(o, dict):
                return {k: clean(v) for k, v in o.items()}
            if isinstance(o, list | tuple):
                return [clean(v) for v in o]
            return o

        out = clean(asdict(self))
        out["drivers"] = self.drivers.to_dict()
        return out

    def step(self, name: str) -> StepSummary:
        for s in self.steps:
            if s.step == name:
                return s
        raise KeyError(f'no step "{name}" in the sweep; steps: {", ".join(s.step for s in self.steps)}')


def _logistic_fit(x: np.ndarray, y: np.ndarray, ridge: float = 1e-2) -> tuple[float, float]:
    """Ridge-penalised logistic regression of y on standardised x: (intercept, slope per sd)."""
    z = (x - x.mean()) / x.std()
    X = np.column_stack([np.ones_like(z), z])
    beta = np.zeros(2)
    penalty = np.array([1e-6, ridge])
    for _ in range(200):
        p = 1.0 / (1.0 + np.exp(-np.clip(X @ beta, -50, 50)))
        grad = X.T @ (y - p) - penalty * beta
        hess = (X * (p * (1 - p))[:, None]).T @ X + np.diag(penalty)
        step = np.linalg.solve(hess, grad)
        beta = beta + step
        if float(np.max(np.abs(step))) < 1e-10:
            break
    return float(beta[0]), float(beta[1])


def factor_effect(factor: str, x: Sequence[float], success: Sequence[bool], n_bins: int = 8) -> FactorEffect:
    """Statistics of one factor against one step's outcomes (see :class:`FactorEffect`)."""
    xs = np.asarray(x, dtype=float)
    ys = np.asarray(success, dtype=float)
    n = int(xs.size)
    bins: list[BinStat] = []
    lo, hi = (float(xs.min()), float(xs.max())) if n else (math.nan, math.nan)
    if n and hi > lo:
        edges = np.linspace(lo, hi, n_bins + 1)
        which = np.clip(np.searchsorted(edges, xs, side="right") - 1, 0, n_bins - 1)
        for b in range(n_bins):
            sel = which == b
            k, m = int(ys[sel].sum()), int(sel.sum())
            ci = wilson_interval(k, m)
            bins.append(BinStat(float(edges[b]), float(edges[b + 1]), m, k,
                                k / m if m else math.nan, ci[0], ci[1]))
    r = p_value = slope = x50 = math.nan
    if n >= 3 and hi > lo and 0 < ys.sum() < n:
        from scipy.stats import pearsonr

        res = pearsonr(xs, ys)
        r, p_value = float(res.statistic), float(res.pvalue)
        b0, b1 = _logistic_fit(xs, ys)
        slope = b1
        if b1 != 0.0:
            cand = float(xs.mean() - b0 / b1 * xs.std())
            x50 = cand if lo <= cand <= hi else math.nan
    return FactorEffect(factor, n, r, p_value, slope, x50, tuple(bins))


def _count_failures(failed: Iterable[dict[str, Any]]) -> tuple[FailureCount, ...]:
    """Failures per criterion code over the failed samples, most frequent first."""
    seen: dict[str, list[Any]] = {}
    for failures in failed:
        for code, ev in (failures or {"unspecified": {}}).items():
            seen.setdefault(code, []).append(ev or {})
    out = []
    for code, evs in seen.items():
        values = [float(e["value"]) for e in evs
                  if isinstance(e.get("value"), int | float) and not isinstance(e["value"], bool)]
        limits = {e.get("limit") for e in evs
                  if isinstance(e.get("limit"), int | float) and not isinstance(e["limit"], bool)}
        out.append(FailureCount(code, len(evs), min(values) if values else None,
                                max(values) if values else None,
                                float(limits.pop()) if len(limits) == 1 else None))
    return tuple(sorted(out, key=lambda f: (-f.count, f.criterion)))


def select_driver(effects: Sequence[FactorEffect], n: int, successes: int,
                  settings: DriverSettings = DriverSettings(),
                  ) -> tuple[tuple[FactorEffect, ...], str | None, DriverStatus]:
    """Name the factor driving a step's failures (see :class:`DriverSettings`).

    Parameters
    ----------
    effects : sequence of FactorEffect
        The step's tested factors only (those of its scene).
    n, successes : int
        The step's samples and successes.
    settings : DriverSettings

    Returns
    -------
    (effects, driver, status)
        ``effects`` with their ``q_value`` set (NaN where ``p_value`` is NaN), the driver's
        factor key or None, and the :data:`DriverStatus`.
    """
    tested = [i for i, e in enumerate(effects) if math.isfinite(e.p_value)]
    q = [math.nan] * len(effects)
    if tested:
        from scipy.stats import false_discovery_control

        adjusted = false_discovery_control([effects[i].p_value for i in tested], method="bh")
        for i, v in zip(tested, np.atleast_1d(adjusted), strict=True):
            q[i] = float(v)
    out = tuple(replace(e, q_value=v) for e, v in zip(effects, q, strict=True))
    if successes in (0, n):
        return out, None, "no_failures"
    if n < settings.min_samples or min(successes, n - successes) < settings.min_each_outcome:
        return out, None, "too_few_samples"
    if not tested:
        return out, None, "nothing_tested"
    significant = [e for e in out if e.q_value < settings.fdr_alpha]
    if not significant:
        return out, None, "none_significant"
    return out, max(significant, key=lambda e: abs(e.correlation)).factor, "named"


# Complexity above C (radon): one pass groups the samples per step; rates, failure counts and factor
# effects follow per step.
def summarize(
    samples: Sequence[SampleParams],
    results: Sequence[TaskResult],
    vary: Sequence[str] = FACTORS,
    n_bins: int = 8,
    *,
    scene_factors: Mapping[str, Collection[str]] | None = None,
    step_numbers: Mapping[str, int] | None = None,
    drivers: DriverSettings = DriverSettings(),
) -> SweepSummary:
    """Per-step statistics of a sweep.

    Parameters
    ----------
    samples : sequence of SampleParams
        The samples, index order.
    results : sequence of TaskResult
        ``results[i]`` for ``samples[i]``. A successful task's value is a dict with
        ``"steps": {step_name: {"success": bool or None, "failures": {code: {"value": float or
        None, "limit": float or None}}}}``; a step with ``success`` None was not evaluated in
        that sample and does not count. A failed step without ``failures`` counts as
        ``"unspecified"``.
    vary : sequence of str
        Factors to analyse (normally ``spec.vary``).
    n_bins : int
        Bins per factor.
    scene_factors : mapping of str to collection of str, optional
        Per step name, the factor keys that can touch its scene
        (:meth:`~asmplan.sim.sweep.PlanSweep.scene_factors`); only those are tested for it
        (all of a step's factors when it is missing).
    step_numbers : mapping of str to int, optional
        Per step name, its plan step number from 1 (:attr:`StepSummary.number`).
    drivers : DriverSettings
        How a driving factor is named.

    Returns
    -------
    SweepSummary
    """
    if len(samples) != len(results):
        raise ValueError(f"summarize: expected as many results as samples, found {len(results)} "
                         f"results for {len(samples)} samples")
    errors: Counter[str] = Counter()
    per_step: dict[str, list[tuple[SampleParams, bool, dict[str, Any]]]] = {}
    for s, r in zip(samples, results, strict=True):
        if r.index != s.index:
            raise ValueError(f"summarize: result {r.index} paired with sample {s.index}")
        if not r.ok:
            errors[r.error_code or "unknown"] += 1
            continue
        steps = r.value.get("steps", {}) if isinstance(r.value, dict) else {}
        for name, out in steps.items():
            if out.get("success") is None:
                continue
            per_step.setdefault(name, []).append(
                (s, bool(out["success"]), dict(out.get("failures") or {})))
    summaries = []
    for name, rows in per_step.items():
        ok = [row[1] for row in rows]
        k, m = sum(ok), len(ok)
        lo, hi = wilson_interval(k, m)
        failures = _count_failures(f for _, success, f in rows if not success)
        allowed = None if scene_factors is None else scene_factors.get(name)
        table: dict[str, list[float]] = {}
        for s, _, _ in rows:
            for key, v in s.factors(name, vary).items():
                if allowed is None or key in allowed:
                    table.setdefault(key, []).append(v)
        effects, driver, status = select_driver(
            [factor_effect(key, v, ok, n_bins) for key, v in table.items() if len(v) == m],
            m, k, drivers)
        summaries.append(StepSummary(
            step=name, n=m, successes=k, rate=k / m, ci_low=lo, ci_high=hi,
            failures=failures, effects=effects, driver=driver, driver_status=status,
            number=None if step_numbers is None else step_numbers.get(name)))
    if step_numbers is not None:
        summaries.sort(key=lambda st: (st.number is None, st.number or 0))
    return SweepSummary(
        n_samples=len(samples), n_errors=sum(errors.values()),
        errors=tuple(sorted(errors.items(), key=lambda kv: (-kv[1], kv[0]))),
        steps=tuple(summaries), drivers=drivers)


