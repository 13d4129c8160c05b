"""Planner: decides the order, the grasps and the collision-free paths, and times them.

Modules by job: ``sequence`` (ranked feasible part orders with networkx, its public types),
``precedence`` (precedence derived from geometry and stability, with evidence),
``sequence_search`` (the exact, beam and depth-first order search), ``access`` (the
gripper's access to a part, screened for the sequence planner), ``blocking`` and
``fcl_oracle`` (which part blocks which), ``partdata`` (what planning needs of each part),
``insertion`` (insertion geometry, the stand-off that clears every bore), ``scene`` (the FCL
planning scene), ``certify`` (path certification), ``layout`` (start poses), ``grasp``
(antipodal grasps), ``ompl_backend`` (the only OMPL user), ``motion`` (one step:
:class:`~asmplan.planner.motion.MotionPlanner`), ``product`` (every step of a product:
:func:`~asmplan.planner.product.plan_product`), ``recheck`` (an independent dense re-check),
``timing`` and ``trajectory`` (timed trajectories), ``plan`` (the plan file and
:class:`~asmplan.planner.plan.AssemblyState`), ``errors``
(:class:`~asmplan.planner.errors.PlanningError` and its kinds).
"""
