"""Knowledge: reads and validates the product YAML into frozen SI-unit types (``Product``,
``Part``, ``Feature``, ``Mate``), ISO 286 fits, materials, frames and the precedence graphs.

Modules: ``loader`` (YAML -> :class:`~asmplan.knowledge.model.Product`, every issue with
file, line and key path), ``schema``, ``model`` (the frozen product types), ``iso286``
(fits), ``materials``, ``frames`` (poses and rotations, the ground floor of the pose math),
``arrays`` (the read-only array copy every frozen type keeps),
``graphs`` (liaison and precedence graphs), ``generator`` (generated test products),
``errors`` (:class:`~asmplan.knowledge.errors.ProductError`).
"""
