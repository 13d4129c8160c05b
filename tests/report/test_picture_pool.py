"""The report's rendered pictures drawn by a picture process forked when the run starts
(report/picture_pool.py), the plots by the run's own process: the same report, byte for byte,
as one process draws, nothing drawn twice, and a picture whose task fails drawn by the report."""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import pytest

from asmplan.fileio import OutputFolder
from asmplan.pipeline import RunSettings, render_while_simulating, run_product, write_outputs
from asmplan.report import picture_pool, plots
from asmplan.report.views import Views
from tests.conftest import example_path

pytestmark = pytest.mark.slow


def digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_pictures_from_the_picture_process_make_the_same_report(tmp_path, monkeypatch) -> None:
    settings = RunSettings(fidelity="fast", workers=2)
    product = example_path("pinhole_station")
    with OutputFolder(tmp_path / "pool") as folder:
        early = render_while_simulating(folder, _load(product), workers=1)
        assert early.pool is not None
        result = run_product(early.pool.product, settings, while_simulating=early,
                             on_step_result=early.step_done)
        # after the simulation this process renders nothing and draws nothing again
        calls: list[str] = []
        for owner, name in ((Views, "render_product"), (Views, "path_view"),
                            (Views, "storyboard"), (Views, "section_view"),
                            (Views, "animation"), (plots, "clamp_force_plot"),
                            (plots, "insertion_plot"), (plots, "precedence_graph_plot"),
                            (plots, "reach_plot")):
            original = getattr(owner, name)

            def counted(*a, _name=name, _original=original, **k):
                calls.append(_name)
                return _original(*a, **k)

            monkeypatch.setattr(owner, name, counted)
        write_outputs(result, folder)
        assert calls == []
        monkeypatch.undo()
        prepared = result.report_views
        every = [s.index for s in result.plan.steps]
        assert sorted(prepared.steps) == every
        assert all(prepared.steps[k].result is result.results.steps[k] for k in every)
        assert early.pool._pool is None  # the picture process was stopped (and reaped)
    pooled = digest(tmp_path / "pool")
    result.report_views = None  # everything drawn by this process after the simulation
    alone = digest(write_outputs(result, tmp_path / "alone"))
    assert pooled.keys() == alone.keys()
    assert {k for k in pooled if pooled[k] != alone[k]} == set()


def test_the_run_process_never_imports_the_renderer(tmp_path) -> None:
    import subprocess

    code = ("import sys\n"
            "from asmplan.cli import main\n"
            f"rc = main(['run', {str(example_path('peg_in_hole'))!r}, '--fidelity', 'fast', "
            f"'-j', '2', '-o', {str(tmp_path / 'out')!r}])\n"
            "assert 'pyrender' not in sys.modules and 'trimesh' not in sys.modules, 'renderer'\n"
            "sys.exit(rc)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "out" / "step02-animation.png").is_file()


def test_a_picture_that_fails_in_the_picture_process_is_drawn_by_the_report(tmp_path,
                                                                             monkeypatch) -> None:
    # the pool submits the task by reference: the picture process runs this module's _broken
    monkeypatch.setattr(picture_pool, "_step_views", _broken)
    with OutputFolder(tmp_path / "out") as folder:
        early = render_while_simulating(folder, _load(example_path("pinhole_station")),
                                        workers=1)
        result = run_product(early.pool.product, RunSettings(fidelity="fast", workers=2),
                             while_simulating=early, on_step_result=early.step_done)
        assert result.results is not None and len(result.results.steps) == len(result.plan.steps)
        monkeypatch.undo()
        out = write_outputs(result, folder)
    assert result.report_views.steps == {}  # no step's pictures came back drawn
    for s in result.plan.steps:
        if s.kind != "fixture":
            assert (out / f"step{s.index + 1:02d}-animation.png").is_file()
            assert (out / f"step{s.index + 1:02d}-section.png").is_file()


def _broken(*a, **k):
    raise RuntimeError("renderer failed")


def _load(path):
    from asmplan.knowledge.loader import load_product

    return load_product(path)
