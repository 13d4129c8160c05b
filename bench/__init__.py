"""Benchmarks of asmplan and the physics validation scenes they share with the tests.

Not part of the installed package: ``asmplan bench`` loads this folder from the source
checkout (see :mod:`asmplan.commands.bench`); the tests import it from the repository root.

* :mod:`bench.suite` -- the sections of ``asmplan bench`` in one namespace, as the CLI loads them
* :mod:`bench.accuracy` -- accuracy of the physics presets (and PyBullet beside MuJoCo)
* :mod:`bench.bounds` -- the asserted accuracy bounds and their check
* :mod:`bench.cost` -- planning, scaling, culling, seed-workstation, sweep and read timings
* :mod:`bench.tables` -- each section's table and the accuracy-vs-cost plot
* :mod:`bench.report` -- a run's record, the machine, the Markdown report
* :mod:`bench.scenarios` -- validation scenes with analytic or converged answers
* :mod:`bench.motion` -- motion planning per step against a direct-insertion OMPL baseline
* :mod:`bench.sequence` -- sequence planning on generated products of growing size
* :mod:`bench.throughput` -- sweep throughput through process pools and Dask
"""
