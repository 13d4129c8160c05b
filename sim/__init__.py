"""Physics check of assembly plans in PyBullet (headless).

Public API (imported lazily, so that ``import asmplan.sim.fidelity`` does not load pybullet)::

    from asmplan.sim import simulate_plan, preset
    results = simulate_plan(plan, product, geometry, fidelity=preset("balanced"))
    results.write("results.json")

* :func:`simulate_plan`, :class:`PlanResults`, :class:`StepResult` (:mod:`asmplan.sim.simulate`)
* :class:`BulletWorld` (:mod:`asmplan.sim.bullet`, the only module importing pybullet)
* :func:`execute_step` (:mod:`asmplan.sim.execute`)
* :class:`Fidelity`, :func:`preset` (:mod:`asmplan.sim.fidelity`)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "BulletWorld": "asmplan.sim.bullet",
    "execute_step": "asmplan.sim.execute",
    "Fidelity": "asmplan.sim.fidelity",
    "preset": "asmplan.sim.fidelity",
    "simulate_plan": "asmplan.sim.simulate",
    "PlanResults": "asmplan.sim.results",
    "StepResult": "asmplan.sim.results",
}

__all__ = [
    "BulletWorld",
    "Fidelity",
    "PlanResults",
    "StepResult",
    "execute_step",
    "preset",
    "simulate_plan",
]

if TYPE_CHECKING:
    from .bullet import BulletWorld
    from .execute import execute_step
    from .fidelity import Fidelity, preset
    from .results import PlanResults, StepResult
    from .simulate import simulate_plan


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'asmplan.sim' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
