"""The report's plan-only pictures rendered while the steps simulate (report/planviews.py)
and each step's result pictures drawn as its result comes back (report/steppictures.py): the
same report, byte for byte, as one rendered after the simulation, and not drawn twice."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from asmplan.fileio import OutputFolder
from asmplan.pipeline import RunSettings, render_while_simulating, run_product, write_outputs
from asmplan.report import plots
from asmplan.report.views import Views
from tests.conftest import example_path

pytestmark = pytest.mark.slow


def digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_pictures_rendered_while_simulating_make_the_same_report(tmp_path, monkeypatch) -> None:
    # two workers (the seed station moves three parts): the steps simulate in forked
    # processes while this one renders
    settings = RunSettings(fidelity="fast", workers=2)
    with OutputFolder(tmp_path / "early") as folder:
        early = render_while_simulating(folder)
        result = run_product(example_path("pinhole_station"), settings,
                             while_simulating=early, on_step_result=early.step_done)
        prepared = result.report_views
        assert prepared is not None and prepared.usable_for(result.plan, folder.stage)
        moving = [s.index for s in result.plan.steps if s.kind != "fixture"]
        assert sorted(prepared.paths) == moving
        assert [k for k, _, _ in prepared.story] == [s.index for s in result.plan.steps]
        assert prepared.images == {"assembled": "assembled.png", "exploded": "exploded.png"}
        assert prepared.graph == "precedence.png"
        assert result.while_simulating_cpu_s > 0
        # every step's result pictures were drawn as its result came back
        every = [s.index for s in result.plan.steps]
        assert sorted(prepared.steps) == every
        assert all(prepared.steps[k].result is result.results.steps[k] for k in every)
        # after the simulation nothing is drawn again
        calls: list[str] = []
        for owner, name in ((Views, "render_product"), (Views, "path_view"),
                            (Views, "storyboard"), (Views, "section_view"),
                            (Views, "animation"), (plots, "clamp_force_plot"),
                            (plots, "insertion_plot")):
            original = getattr(owner, name)

            def counted(*a, _name=name, _original=original, **k):
                calls.append(_name)
                return _original(*a, **k)

            monkeypatch.setattr(owner, name, counted)
        write_outputs(result, folder)
        assert calls == []
        monkeypatch.undo()
    # the stages add up: the early CPU is counted in "report", not in "simulate"
    assert result.cpu_s["report"] >= result.while_simulating_cpu_s
    early = digest(tmp_path / "early")
    result.report_views = None  # everything rendered after the simulation
    late = digest(write_outputs(result, tmp_path / "late"))
    assert early.keys() == late.keys()
    assert {k for k in early if early[k] != late[k]} == set()


def test_pictures_for_another_plan_or_folder_are_not_used(tmp_path) -> None:
    with OutputFolder(tmp_path / "a") as folder:
        result = run_product(example_path("peg_in_hole"), RunSettings(fidelity="fast", workers=1),
                             while_simulating=render_while_simulating(folder))
        prepared = result.report_views
        assert prepared.usable_for(result.plan, folder.stage)
        assert not prepared.usable_for(result.plan, tmp_path / "elsewhere")
        assert not prepared.usable_for(None, folder.stage)
    # written elsewhere, the report renders every picture itself
    other = write_outputs(result, tmp_path / "b")
    for name in ("assembled.png", "step02-path.png", "step01-after.png", "precedence.png"):
        assert (other / name).is_file(), name


def test_a_step_picture_that_fails_while_simulating_is_drawn_by_the_report(tmp_path,
                                                                           monkeypatch) -> None:
    import asmplan.report.planviews as planviews

    def broken(*a, **k):
        raise RuntimeError("renderer failed")

    monkeypatch.setattr(planviews, "render_step_pictures", broken)
    with OutputFolder(tmp_path / "out") as folder:
        early = render_while_simulating(folder)
        result = run_product(example_path("pinhole_station"),
                             RunSettings(fidelity="fast", workers=2),
                             while_simulating=early, on_step_result=early.step_done)
        # the simulation's results are all kept; no step's pictures count as drawn
        assert result.results is not None and len(result.results.steps) == len(result.plan.steps)
        assert result.report_views.steps == {}
        monkeypatch.undo()
        out = write_outputs(result, folder)
    for s in result.plan.steps:
        if s.kind != "fixture":
            assert (out / f"step{s.index + 1:02d}-clamp-force.png").is_file()
