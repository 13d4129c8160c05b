"""The root of asmplan's exceptions: every error asmplan raises on purpose is an AsmplanError.

The tree (each error carries its evidence as attributes; the text is for people):

* :class:`~asmplan.knowledge.errors.ProductError` -- bad input, every issue with its file,
  line and key path (also a ``ValueError``); with
  :class:`~asmplan.planner.sequence.PrecedenceConflictError` below it
* :class:`~asmplan.knowledge.iso286.FitError`, :class:`~asmplan.parts.geometry.GeometryError`,
  :class:`~asmplan.parts.meshfile.MeshFileError`, :class:`~asmplan.parts.mesh.DegenerateHullError`,
  :class:`~asmplan.sim.scene.PlanProductMismatchError`, :class:`~asmplan.knowledge.robot.UrdfError`,
  :class:`~asmplan.knowledge.press_fit.PressFitError`,
  :class:`~asmplan.parts.step_brep.StepReadError`,
  :class:`~asmplan.parts.cad_types.CadImportError` -- invalid values (also ``ValueError``)
* :class:`~asmplan.planner.errors.PlanningError` -- no plan exists, with the failing step,
  part and colliding pairs (``StartInCollisionError``, ``NoPathError``,
  ``InsertionBlockedError``, ``NoGraspError``, ``GripInfeasibleError``,
  ``NoFeasibleSequenceError``)
* :class:`~asmplan.sim.bullet.BulletError` -- the physics engine refused a body (also a
  ``RuntimeError``)
* :class:`~asmplan.sim.sweep.SweepError` -- the sweep's journal or executor (also a
  ``RuntimeError``)

A failed physical check is not an exception: it is a result with its failed criteria, each
with its measured value and limit (:func:`asmplan.sim.results.criteria_table`).
"""

from __future__ import annotations


class AsmplanError(Exception):
    """Base of every error asmplan raises on purpose."""
