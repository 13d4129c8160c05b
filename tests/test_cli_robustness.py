"""Exit codes hold under signals and pipes, and sweep's arguments are bounded (issue 14).

The console script runs in a subprocess of its own process group, as a terminal runs it:
Ctrl-C reaches the main process and its simulator workers at once.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from asmplan.cli import main
from tests.conftest import example_path

ASMPLAN = [sys.executable, "-c", "from asmplan.cli import entry; entry()"]


def test_a_closed_pipe_ends_quietly_with_141() -> None:
    # `asmplan graph ... | head -0`: the reader is gone before the first write (closing it
    # after reading a line would race with the writer filling the pipe's buffer)
    proc = subprocess.Popen([*ASMPLAN, "graph", str(example_path("gear_unit"))], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert err == ""


def _group_alive(pgid: int) -> list[str]:
    out = subprocess.run(["ps", "-eo", "pgid=,pid=,stat="], capture_output=True, text=True).stdout
    return [line for line in out.splitlines()
            if line.split()[0] == str(pgid) and not line.split()[2].startswith("Z")]


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="process groups and ps as on Linux")
@pytest.mark.parametrize("stage", ["sequence:", "simulate:"])
def test_ctrl_c_at_any_stage_exits_130_and_leaves_no_worker(stage, tmp_path: Path) -> None:
    """SIGINT to the whole group (what a terminal's Ctrl-C does) once ``stage`` shows on the
    progress output: before the worker pool exists, and while its workers simulate."""
    proc = subprocess.Popen([*ASMPLAN, "run", str(example_path("pinhole_station")), "-o", str(tmp_path / "out"),
                             "--fidelity", "balanced", "--no-report", "-j", "2"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    assert proc.stderr is not None
    seen = []
    for raw in proc.stderr:
        seen.append(raw.decode())
        if seen[-1].startswith(stage):
            break
    else:
        pytest.fail(f"the run ended before {stage}: {''.join(seen)}")
    os.killpg(proc.pid, signal.SIGINT)
    rest = proc.stderr.read().decode()
    code = proc.wait(timeout=120)
    assert code == 130, "".join(seen) + rest
    assert "Traceback" not in rest and "internal error" not in rest, rest
    assert rest.strip().endswith("asmplan: interrupted")
    deadline = time.monotonic() + 10
    while _group_alive(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert _group_alive(proc.pid) == []


def test_sweep_refuses_absurd_sample_counts_and_repeated_factors(capsys, tmp_path: Path) -> None:
    product = str(example_path("peg_in_hole"))
    assert main(["sweep", product, "--samples", "1000000000", "-o", str(tmp_path / "s")]) == 2
    assert "expected at most 100,000 samples" in capsys.readouterr().err
    assert main(["sweep", product, "--samples", "10", "--vary", "clearance,clearance",
                 "-o", str(tmp_path / "s")]) == 2
    assert "expected each factor once, found clearance more than once" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_a_frictionless_peg_fails_with_its_reason_and_no_infinity_in_json(tmp_path: Path, capsys) -> None:
    """``friction: 0`` on the peg: no friction grip can hold it (needs inf N): ``run`` says
    so (exit 1) and writes strict JSON (the required force is null, never Infinity)."""
    text = example_path("peg_in_hole").read_text(encoding="utf-8").replace(
        "  - name: peg\n    material: steel\n", "  - name: peg\n    material: steel\n    friction: 0\n")
    assert "friction: 0" in text
    product = tmp_path / "frictionless.yaml"
    product.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["run", str(product), "-o", str(out), "--fidelity", "fast", "--no-report", "-j", "1"])
    captured = capsys.readouterr()
    assert code == 1, captured.err
    assert "grip infeasible: needs inf N per finger" in captured.out
    for f in out.glob("*.json"):
        assert "Infinity" not in f.read_text(encoding="utf-8") and "NaN" not in f.read_text(encoding="utf-8")
    assert '"required_N": null' in (out / "summary.json").read_text(encoding="utf-8")
