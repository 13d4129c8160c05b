"""Shared fixtures: the example products and the reference data beside the checkout."""

from __future__ import annotations

import os
import sys
from pathlib import Path


def _pin_openblas_kernels() -> None:
    """OpenBLAS (under numpy and scipy) chooses its kernels by CPU (SkylakeX, Zen, Haswell, ...)
    and they round differently in the last bit: a plan's principal axes, and through them a
    grasp, a clamp force and a jam, then differ between machines. Measured: the goldens were
    written on an AVX-512 Intel machine (OpenBLAS SkylakeX kernels); on an AMD EPYC its own
    kernels moved every example's plan.json (four goldens) and flipped two knife-edge verdicts
    (the gear unit's shaft at FAST, the gearbox shaft at BALANCED; docs/physics.md). With
    OPENBLAS_CORETYPE=SkylakeX the EPYC reproduces the goldens bit for bit. Every test process
    uses the SkylakeX kernels where the CPU has AVX-512, else Haswell's (AVX2 + FMA: the
    goldens then do not apply, tests/test_golden.py skips); dev.sh does the same for every
    command. It replaces a kernel set in the
    environment (this machine kind sets OPENBLAS_CORETYPE=Haswell for every process), and must
    be set before numpy loads OpenBLAS."""
    if "numpy" in sys.modules:
        return
    try:
        flags = set(Path("/proc/cpuinfo").read_text().split())
    except OSError:
        return
    if {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"} <= flags:
        os.environ["OPENBLAS_CORETYPE"] = "SkylakeX"
    elif {"avx2", "fma"} <= flags:
        os.environ["OPENBLAS_CORETYPE"] = "Haswell"


_pin_openblas_kernels()

import pytest  # noqa: E402 (after the kernels are pinned)
from hypothesis import settings  # noqa: E402 (after the kernels are pinned)

from asmplan.knowledge.loader import load_product  # noqa: E402 (after the kernels are pinned)
from asmplan.knowledge.model import Product  # noqa: E402 (after the kernels are pinned)

# Property tests draw the same examples on every run (CI must not pass or fail by chance);
# HYPOTHESIS_PROFILE=explore draws new random examples, to hunt for failures by hand.
settings.register_profile("deterministic", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
SHARED = REPO.parent / "shared"
EXAMPLE_NAMES = ("peg_in_hole", "pinhole_station", "gear_unit")


def example_path(name: str) -> Path:
    return EXAMPLES / f"{name}.yaml"


@pytest.fixture(scope="session")
def examples() -> dict[str, Product]:
    """Every bundled example product, loaded once."""
    return {name: load_product(example_path(name)) for name in EXAMPLE_NAMES}


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--regen-golden", action="store_true",
                     help="rewrite tests/fixtures/golden/ from this checkout's outputs "
                          "(only when behaviour is meant to change)")
