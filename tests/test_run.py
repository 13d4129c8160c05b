"""`asmplan run`: the whole job, its outputs, exit codes, determinism and atomicity."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from asmplan.cli import main
from asmplan.pipeline import RunSettings, run_product, write_outputs
from tests.conftest import REPO, example_path

pytestmark = pytest.mark.slow


def digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_run_writes_plan_results_and_a_report_that_shows_them(tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code = main(["run", str(example_path("peg_in_hole")), "-o", str(out), "--fidelity", "fast"])
    stdout = capsys.readouterr().out
    assert code == 0, stdout
    assert "peg_in_hole: every step succeeds" in stdout
    for name in ("plan.json", "results.json", "sequence.json", "summary.json", "report.html",
                 "assembled.png", "exploded.png", "precedence.png", "step01-after.png",
                 "step02-after.png", "step02-path.png", "step02-section.png",
                 "step02-animation.png", "step02-clamp-force.png", "step02-insertion.png"):
        assert (out / name).is_file(), name
    html = (out / "report.html").read_text()
    # steps count from 1 (the block in its fixture is step 1), the same in files and text
    assert "every step succeeds" in html and "Step 2: peg" in html
    for img in ("assembled.png", "step02-clamp-force.png", "step02-path.png",
                "step02-animation.png"):
        assert f'src="{img}"' in html
    # the assembled view shows something: many non-background pixels, varied shading
    pixels = np.asarray(Image.open(out / "assembled.png").convert("RGB"), dtype=float)
    non_white = (pixels < 245).any(axis=2).mean()
    assert 0.05 < non_white < 0.95
    results = json.loads((out / "results.json").read_text())
    assert results["steps"][1]["outcome"]["success"] is True


def test_same_input_and_seed_give_identical_plan_and_results(tmp_path) -> None:
    runs = []
    for i in range(2):
        result = run_product(example_path("peg_in_hole"), RunSettings(fidelity="fast"))
        folder = write_outputs(result, tmp_path / f"run{i}", report=False)
        runs.append(digest(folder))
    for name in ("plan.json", "results.json", "sequence.json", "summary.json"):
        assert runs[0][name] == runs[1][name], name


def test_physical_failure_exits_1_and_names_the_criterion(tmp_path, capsys) -> None:
    text = example_path("peg_in_hole").read_text().replace(
        "precedence:", "process: {max_insertion_force: 0.01}\nprecedence:")
    product = tmp_path / "weak.yaml"
    product.write_text(text)
    code = main(["run", str(product), "-o", str(tmp_path / "out"), "--fidelity", "fast", "--no-report"])
    stdout = capsys.readouterr().out
    assert code == 1
    assert "FAILED" in stdout and "insertion force" in stdout
    assert "fail physically" in stdout


def test_no_plan_exits_1_with_the_obstacle(tmp_path, capsys) -> None:
    code = main(["run", str(REPO / "tests" / "fixtures" / "blocked_product.yaml"), "-o",
                 str(tmp_path / "out"), "--fidelity", "fast"])
    stdout = capsys.readouterr().out
    assert code == 1
    assert "no plan" in stdout and "bridge" in stdout
    # the report is still written and says why
    assert "No plan" in (tmp_path / "out" / "report.html").read_text()


def test_bad_input_exits_2(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(example_path("peg_in_hole").read_text().replace("diameter: 10, length: 40", "diameter: -1, length: 40"))
    assert main(["run", str(bad), "-o", str(tmp_path / "out")]) == 2
    assert "parts[1].geometry.diameter: expected a positive length" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (from /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has exited (its parent, init, reaps it)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
def test_killing_a_run_midway_leaves_the_previous_outdir_intact(tmp_path, sig) -> None:
    out = tmp_path / "out"
    assert main(["run", str(example_path("peg_in_hole")), "-o", str(out), "--fidelity", "fast",
                 "--no-report"]) == 0
    before = digest(out)
    # at BALANCED its simulate stage lasts seconds (at FAST ~1 s, which a loaded machine's
    # scan of /proc below could outlast: the run then ends before the signal and exits 0)
    proc = subprocess.Popen([sys.executable, "-m", "asmplan", "run", str(example_path("pinhole_station")),
                             "-o", str(out), "--fidelity", "balanced"], stderr=subprocess.PIPE,
                            text=True, cwd=tmp_path)
    # wait until it is simulating (outputs are being produced), then kill it
    deadline = time.monotonic() + 120
    assert proc.stderr is not None
    for line in proc.stderr:
        if line.startswith("simulate:") or time.monotonic() > deadline:
            break
    workers = _children(proc.pid)  # the simulator processes it forked
    os.kill(proc.pid, sig)
    proc.wait(timeout=60)
    assert proc.returncode != 0
    assert digest(out) == before
    # its workers die with it: none is left behind as an orphan
    deadline = time.monotonic() + 10
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [p for p in workers if _alive(p)]
    if sig == signal.SIGINT:  # a clean interrupt removes its staging folder at once
        assert proc.returncode == 130
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    # the next run cleans what a killed one left behind and replaces the folder whole
    assert main(["run", str(example_path("peg_in_hole")), "-o", str(out), "--fidelity", "fast",
                 "--no-report"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_simulating_while_planning_gives_the_results_of_simulating_afterwards(tmp_path) -> None:
    from asmplan.planner.sequence import SequenceSettings
    from asmplan.sim.fidelity import preset
    from asmplan.sim.simulate import simulate_plan

    # gear_unit ranked without the gripper screening, with a delicate collar (at most 0.6 N
    # of clamp force, as in tests/report/test_report_content.py): the planner gives up a
    # better-ranked order (the collar after the cover: its only grasp there, 45 deg over the
    # cover, needs 0.84 N) before one plans, so steps started for an abandoned order must not
    # leak into the results. (The plain collar is held there and that order plans.)
    text = example_path("gear_unit").read_text()
    start = "    start: {location: tray, xyz: [80, 220, 10], rpy: [0, 90, 0]}    # on edge, bore along x\n"
    assert start in text
    delicate = tmp_path / "gear_unit.yaml"
    delicate.write_text(text.replace(start, start + "    handling: {max_clamp_force: 0.6}\n"))
    blind = SequenceSettings(gripper_access=False)
    for name, path in (("pinhole_station", example_path("pinhole_station")),
                       ("gear_unit", delicate)):
        piped = run_product(path, RunSettings(fidelity="fast", workers=2, sequence=blind))
        assert piped.plan is not None and piped.results is not None
        if name == "gear_unit":
            assert "could not be planned" in piped.plan.sequence_note
        one = run_product(path, RunSettings(fidelity="fast", workers=1, sequence=blind))
        assert one.plan.to_json() == piped.plan.to_json()
        serial = simulate_plan(piped.plan, piped.product, piped.geometry, preset("fast"), workers=1)
        assert piped.results.to_json() == serial.to_json() == one.results.to_json(), name


def test_a_run_without_report_imports_neither_trimesh_nor_scipy(tmp_path) -> None:
    # they cost ~0.5 s of imports per run (scipy.spatial pulls in scipy.special); the run
    # path uses asmplan.parts.mesh instead, and only mesh files and the report need trimesh.
    # -j 1 simulates in this process, so the simulator's imports are seen too.
    code = (
        "import sys\n"
        "from asmplan.cli import main\n"
        f"code = main(['run', {str(example_path('pinhole_station'))!r}, '-o', {str(tmp_path / 'o')!r},"
        " '--fidelity', 'fast', '--no-report', '-j', '1'])\n"
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('trimesh', 'scipy'))\n"
        "print(code, heavy[:5])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "0 []"


def test_gear_unit_succeeds_at_every_step_at_balanced() -> None:
    """The bundled gear unit is an ordinary product with chamfered fits: a real cell assembles
    it, so every step succeeds at BALANCED within the judge's tolerances (0.5 mm, 2 deg).
    Guards two regressions measured on main d45766b: the wheel on its H7/h6 hub ended
    0.916 mm / 2.68 deg off when the synchronised jaws' gear constraint corrected its whole
    drift each step (ERP 1.0), and the shaft jammed in the bearing block at ERP 0.2 (tilt
    0.24 deg at 21 mm of 50); at ERP 0.5 both pass (0.023 mm, 0.099 mm)."""
    result = run_product(example_path("gear_unit"), RunSettings(fidelity="balanced"))
    assert result.plan is not None and result.results is not None
    outcomes = {s.part: s.outcome for s in result.results.steps
                if s.outcome is not None}
    assert set(outcomes) >= {"bearing_block", "shaft", "wheel", "collar", "post_1", "post_2",
                             "cover"}
    failed = {part: o.reasons for part, o in outcomes.items() if not o.success}
    assert not failed, failed
    for part, o in outcomes.items():
        assert o.final_position_error_m < 0.5e-3, (part, o.final_position_error_m)
        assert o.final_angle_error_rad < np.radians(2.0), (part, o.final_angle_error_rad)
