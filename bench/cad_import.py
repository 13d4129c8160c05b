"""Benchmark of ``asmplan import``: the 20-part STEP fixture and the mesh folders (reported,
never asserted; the issue's target is < 10 s for a 20-part STEP on 2 cores)."""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from pathlib import Path

CAD_FIXTURES = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "cad"  # bench/ is beside tests/
IMPORT_RUNS = 3


@dataclass(frozen=True)
class ImportTiming:
    """Median and range of ``import_assembly`` wall times (read, recognise, propose mates),
    and the median CPU time of this process (user + system, all threads): on shared cores the
    wall time carries the machine's load, the CPU time does not."""

    source: str
    parts: int
    features: int
    mates: int
    runs_s: tuple[float, ...]
    cpu_runs_s: tuple[float, ...] = ()

    @property
    def median_s(self) -> float:
        return statistics.median(self.runs_s)

    @property
    def median_cpu_s(self) -> float:
        return statistics.median(self.cpu_runs_s) if self.cpu_runs_s else float("nan")


def bench(runs: int = IMPORT_RUNS, folder: Path = CAD_FIXTURES) -> list[ImportTiming]:
    """Time the import of the 20-part STEP and of each fixture's mesh folder."""
    from asmplan.parts.cad_import import import_assembly

    sources = [folder / "two_stations_20.step", folder / "locating_fixture_meshes",
               folder / "angle_bracket_meshes"]
    out = []
    for src in sources:
        if not src.exists():
            continue
        times, cpu = [], []
        for _ in range(runs):
            t0, c0 = time.perf_counter(), time.process_time()
            result = import_assembly(src)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        out.append(ImportTiming(src.name, len(result.parts), sum(len(p.features) for p in result.parts),
                                len(result.mates), tuple(times), tuple(cpu)))
    return out


def format_import(rows: list[ImportTiming]) -> str:
    lines = ["| input | parts | features | mates | median s | range s | median CPU s |",
             "| --- | ---: | ---: | ---: | ---: | --- | ---: |"]
    for r in rows:
        lines.append(f"| {r.source} | {r.parts} | {r.features} | {r.mates} | {r.median_s:.2f} | "
                     f"{min(r.runs_s):.2f}-{max(r.runs_s):.2f} | {r.median_cpu_s:.2f} |")
    return "\n".join(lines) + "\n"


__all__ = ["ImportTiming", "bench", "format_import"]
