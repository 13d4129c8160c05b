"""Benchmarks of asmplan and the physics validation scenes they share with the tests.

Not part of the installed package: ``asmplan bench`` loads this folder from the source
checkout (see :mod:`asmplan.commands.bench`); the tests import it from the repository root.

* :mod:`bench.suite` -- the sections of ``asmplan bench``, their bounds and the Markdown report
* :mod:`bench.scenarios` -- validation scenes with analytic or converged answers
* :mod:`bench.motion` -- motion planning per step against a direct-insertion OMPL baseline
* :mod:`bench.sequence` -- sequence planning on generated products of growing size
* :mod:`bench.throughput` -- sweep throughput through process pools and Dask
"""
