"""asmplan: plan robot assembly from a product YAML and prove every step in simulation.

The public API, for scripts and notebooks (each name is imported on first use, so importing
``asmplan`` stays cheap):

========================  =====================================================================
``load_product``          read and validate a product YAML -> :class:`Product` (SI units)
``ProductGeometry``       meshes, mass properties, feature frames, collision models per part;
                          built once per product and passed to every stage below
``FclOracle``             which part blocks which, from the geometry (for ``plan_sequence``)
``plan_sequence``         ranked feasible sequences, every precedence explained
``plan_product``          grasps, collision-free paths and timed trajectories -> ``PlanResult``
``simulate_plan``         every step in PyBullet -> :class:`PlanResults`
``preset``                a fidelity preset by name ("fast", "balanced", "accurate")
``run_product``           all of the above in one call -> :class:`RunResult`
``write_outputs``         plan.json, results.json and the HTML report, written atomically
``RunSettings``           settings of a run (fidelity, planner, sequence weights)
``PlannerSettings``       planner choice, time budget, seed, check resolutions
``render_product``        an offscreen PNG of the assembled product
``AssemblyState``         where every part is while a step runs (apart from the product)
``AsmplanError``          the root of every error asmplan raises on purpose
========================  =====================================================================
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_EXPORTS = {
    "load_product": "asmplan.knowledge.loader",
    "ProductError": "asmplan.knowledge.errors",
    "Product": "asmplan.knowledge.model",
    "ProductGeometry": "asmplan.parts.models",
    "FclOracle": "asmplan.planner.fcl_oracle",
    "plan_sequence": "asmplan.planner.sequence",
    "SequenceSettings": "asmplan.planner.sequence",
    "plan_product": "asmplan.planner.product",
    "PlannerSettings": "asmplan.planner.settings",
    "Plan": "asmplan.planner.plan",
    "simulate_plan": "asmplan.sim.simulate",
    "PlanResults": "asmplan.sim.results",
    "preset": "asmplan.sim.fidelity",
    "Fidelity": "asmplan.sim.fidelity",
    "run_product": "asmplan.pipeline",
    "write_outputs": "asmplan.pipeline",
    "RunSettings": "asmplan.pipeline",
    "RunResult": "asmplan.pipeline",
    "render_product": "asmplan.report.views",
    "AsmplanError": "asmplan.errors",
    "AssemblyState": "asmplan.planner.plan",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'asmplan' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
