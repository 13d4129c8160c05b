"""``asmplan bench [--quick] [--out FILE] [--sections ...]``: measure accuracy, cost and scaling.

Full run (default): every section (accuracy at every preset, the seed workstation end to end
at FAST, motion planning vs direct OMPL, scaling on generated products, scene culling, sweep
throughput, reading a 2,000-part file); prints the tables and writes
``docs/benchmarks.md`` and ``docs/benchmarks.png`` (the accuracy-vs-cost plot beside it).
``--quick`` (CI): the accuracy scenarios at FAST and BALANCED and the 5 um clearance fit at
BALANCED (bench/fits.py) only. ``--quick``, ``--sections`` or ``--presets`` write nothing unless
``--out`` is given (a part of the run never replaces the full run's docs/benchmarks.md).

Exit codes: 0 every asserted accuracy figure is within its bound, 1 a figure regressed
(``REGRESSION: <figure> = <value> exceeds bound <bound>`` on stderr), 2 bad usage, or
benchmarks not available. Time is never asserted.

The benchmarks and their validation scenes live in the checkout's top-level ``bench/`` folder,
not in the installed package: ``asmplan bench`` runs from a source checkout (an editable
install, ``bash dev.sh bench``). From a wheel it says so and exits 2.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
import time
from pathlib import Path
from types import ModuleType

from ..fileio import atomic_write_bytes, atomic_write_text

CHECKOUT = Path(__file__).resolve().parents[2]
"""The source checkout this asmplan runs from (for a wheel: site-packages, without bench/)."""

SECTIONS: tuple[str, ...] = ("accuracy", "fits", "seed", "planning", "arm", "scaling", "culling",
                            "sweep", "read", "import")
SCALING_SIZES: tuple[int, ...] = (5, 10, 20, 50, 100)


def load_suite() -> ModuleType | None:
    """``bench/suite.py`` of the checkout, or None when asmplan is not run from a checkout.

    The checkout goes to the front of ``sys.path`` so that the worker processes of the sweep
    section (which unpickle tasks defined in ``bench/``) import the same files.
    """
    folder = CHECKOUT / "bench"
    loaded = sys.modules.get("bench")
    if loaded is None:
        if not ((CHECKOUT / "pyproject.toml").is_file() and (folder / "suite.py").is_file()):
            return None  # not a source checkout (a wheel in site-packages)
        sys.path.insert(0, str(CHECKOUT))
    elif Path(str(getattr(loaded, "__file__", ""))).resolve().parent != folder:
        return None  # another distribution's "bench" package
    return importlib.import_module("bench.suite")


def _sections(text: str) -> tuple[str, ...]:
    items = tuple(s.strip() for s in text.split(",") if s.strip())
    bad = [s for s in items if s not in SECTIONS]
    if bad or not items:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated subset of {','.join(SECTIONS)}, found \"{text}\"")
    return items


def _presets(text: str) -> tuple[str, ...]:
    from ..sim.fidelity import PRESETS

    items = tuple(s.strip().lower() for s in text.split(",") if s.strip())
    bad = [s for s in items if s not in PRESETS]
    if bad or not items:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated subset of {','.join(PRESETS)}, found \"{text}\"")
    return items


def _sizes(text: str) -> tuple[int, ...]:
    try:
        items = tuple(int(s) for s in text.split(",") if s.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected comma-separated integers, found "{text}"') from None
    if not items or min(items) < 2:
        raise argparse.ArgumentTypeError(f'expected part counts >= 2, found "{text}"')
    return items


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench", help="benchmark accuracy vs cost, planning, scaling, culling and sweeps",
        description="Measure the physics presets' accuracy against analytic values and a converged "
                    "reference (asserted against documented bounds), and report planning time, "
                    "scaling, scene culling and sweep throughput (never asserted).")
    p.add_argument("--quick", action="store_true",
                   help="CI mode: accuracy at fast and balanced only; writes nothing without --out")
    p.add_argument("--out", type=Path, default=None,
                   help="Markdown file to write (default docs/benchmarks.md in a full run only: with "
                        "--quick, --sections or --presets nothing is written without --out); the "
                        "plot goes beside it as .png")
    p.add_argument("--sections", type=_sections, default=None,
                   help=f"comma-separated subset of {','.join(SECTIONS)} "
                        "(default: all; quick: accuracy,fits)")
    p.add_argument("--presets", type=_presets, default=None,
                   help="presets of the accuracy section (default: all; quick: fast,balanced)")
    p.add_argument("--sizes", type=_sizes, default=SCALING_SIZES,
                   help="part counts of the scaling section (default: %(default)s)")
    p.set_defaults(func=run)


def default_out(args: argparse.Namespace) -> Path | None:
    """Where the Markdown report goes: ``--out``, else docs/benchmarks.md only for a full run.

    A run of some sections or presets (or ``--quick``) writes nothing unless ``--out`` is given,
    so that it never replaces the full run's docs/benchmarks.md with a part of its tables.
    """
    if args.out is not None:
        return Path(args.out)
    if args.quick or args.sections or args.presets:
        return None
    return Path("docs/benchmarks.md")


# Complexity above C (radon): one block per benchmark section, in the order the report prints them.
def run(args: argparse.Namespace) -> int:
    b = load_suite()
    if b is None:
        print("asmplan bench: the benchmarks live in the bench/ folder of a source checkout and "
              "are not installed; clone the repository and run `bash dev.sh bench`",
              file=sys.stderr)
        return 2
    sections = args.sections or (("accuracy", "fits") if args.quick else SECTIONS)
    presets = args.presets or (("fast", "balanced") if args.quick else ("fast", "balanced", "accurate"))
    out = default_out(args)
    t_start = time.perf_counter()
    argv = ["asmplan", "bench"] + (["--quick"] if args.quick else [])
    if args.sections:
        argv += ["--sections", ",".join(args.sections)]
    if args.presets:
        argv += ["--presets", ",".join(args.presets)]
    rep = b.BenchReport(quick=args.quick, machine=b.machine_description(),
                        started=time.strftime("%Y-%m-%d %H:%M %Z"), command=" ".join(argv))

    def log(line: str) -> None:
        print(f"  [{time.perf_counter() - t_start:6.1f} s] {line}", file=sys.stderr, flush=True)

    def show(title: str, text: str) -> None:
        print(f"\n## {title}\n\n{text}", flush=True)

    if "accuracy" in sections:
        log(f"accuracy: presets {', '.join(presets)} and the reference runs")
        rep.accuracy = b.run_accuracy(presets, check_convergence=not args.quick,
                                      with_peers=not args.quick, log=log)
        rep.regressions = b.check_bounds(rep.accuracy.figures)
        show("Accuracy vs cost", b.format_accuracy_summary(rep.accuracy) + "\n"
             + b.format_accuracy(rep.accuracy))
        if rep.accuracy.peers:
            show("PyBullet and MuJoCo side by side", b.format_peers(rep.accuracy.peers,
                                                                     "balanced"))
        if rep.accuracy.peer_matches:
            ladder = importlib.import_module("bench.peer_ladder")
            show("The jam scenes at equal accuracy",
                 ladder.format_peer_matches(rep.accuracy.peer_matches, "balanced"))
    if "fits" in sections:
        fits = importlib.import_module("bench.fits")
        if args.quick:
            log("fits: the 5 um fit at BALANCED against capture geometry")
            rep.fits = fits.run_fits(fits.QUICK_FITS, ("balanced",), reference=False,
                                     seed_job=False, log=log)
        else:
            log("fits: 5-50 um clearance fits at every preset and the reference; the seed job")
            rep.fits = fits.run_fits(log=log)
        rep.regressions.extend(b.check_bounds(rep.fits.figures))
        show("Clearance fits", fits.format_fits(rep.fits))
    if "seed" in sections:
        log(f"seed workstation at FAST without the report, {b.SEED_RUNS} runs; at BALANCED with "
            f"the report, {b.SEED_REPORT_RUNS} runs")
        rep.seed = b.run_seed_timing(log=log)
        show("Seed workstation end to end", b.format_seed_timing(rep.seed))
    if "planning" in sections:
        log("planning: bundled examples vs direct OMPL insertion")
        rep.planning = b.run_planning()
        show("Motion planning per step", b.format_planning(rep.planning))
    if "arm" in sections:
        log("arm: IK per waypoint and planning per step with and without the arm")
        rep.arm = b.run_arm(log=log)
        show("The arm", b.format_arm(rep.arm))
    kept = None
    if "scaling" in sections:
        log(f"scaling: generated products of {', '.join(map(str, args.sizes))} parts")
        rep.scaling, kept = b.run_scaling(args.sizes, log=log)
        show("Scaling", b.format_scaling(rep.scaling))
    if "culling" in sections:
        log(f"culling: the {b.CULLING_SIZE}-part product, culled vs whole scene")
        rep.culling = []
        for example in (None, "gear_unit"):
            try:
                rep.culling.append(b.run_culling(kept, example=example))
            except Exception as exc:  # reported in the table, like a scaling failure
                rep.culling.append(b.CullingResult(b.CULLING_SIZE, 0, float("nan"), float("nan"), False,
                                                   failure=f"{type(exc).__name__}: {exc}",
                                                   product=example or "generated"))
            if not rep.culling[-1].failure:
                break
        show("Scene culling", b.format_culling(rep.culling))
    if "sweep" in sections:
        log("sweep throughput: 1 and 2 local workers, Dask")
        rep.sweep = b.run_sweep_throughput()
        show("Sweep throughput", b.format_sweep(rep.sweep))
    if "read" in sections:
        log(f"read: a generated {b.READ_PARTS}-part product file, {b.READ_RUNS} runs")
        rep.read = b.run_read()
        show("Reading a large product file", b.format_read(rep.read))
    if "import" in sections:
        cad = importlib.import_module("bench.cad_import")
        log("CAD import: the 20-part STEP and two mesh folders, 3 runs each")
        rep.cad_import = cad.bench()
        show("CAD import", cad.format_import(rep.cad_import))
    rep.wall_s = time.perf_counter() - t_start
    if out is not None:
        plot = None
        if rep.accuracy is not None:
            plot = out.with_suffix(".png")
            atomic_write_bytes(plot, b.accuracy_plot_png(rep.accuracy))
        atomic_write_text(out, b.format_markdown(rep, plot.name if plot else None))
        log(f"wrote {out}" + (f" and {plot}" if plot else ""))
    for r in rep.regressions:
        print(str(r), file=sys.stderr)
    if rep.regressions:
        print(f"asmplan bench: {len(rep.regressions)} accuracy figure(s) beyond their bound",
              file=sys.stderr)
        return 1
    n = 0 if rep.accuracy is None else sum(1 for f in rep.accuracy.figures if f.asserted)
    n += 0 if rep.fits is None else sum(1 for f in rep.fits.figures if f.asserted)
    log(f"done in {rep.wall_s:.0f} s" + (f"; {n} accuracy figures within their bounds" if n else ""))
    return 0
