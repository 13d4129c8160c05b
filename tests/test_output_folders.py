"""Output paths: asmplan never deletes or overwrites what it did not write (issue 14, item 1).

Each refusal happens before any planning or simulation and exits 2 with the path and the
reason; the user's files are byte for byte what they were.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from asmplan import fileio
from asmplan.cli import main
from asmplan.fileio import (
    OUTPUT_MARKER,
    OutputFolder,
    OutputPathError,
    atomic_write_text,
    check_output_file,
    check_output_folder,
    staged_directory,
)
from tests.conftest import example_path


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture()
def user_folder(tmp_path: Path) -> Path:
    """A user's working folder: their product file and their notes."""
    folder = tmp_path / "work"
    folder.mkdir()
    shutil.copy(example_path("peg_in_hole"), folder / "product.yaml")
    (folder / "notes.txt").write_text("torque values from the supplier\n")
    return folder


def test_run_into_the_current_folder_is_refused_and_deletes_nothing(user_folder, monkeypatch, capsys):
    monkeypatch.chdir(user_folder)
    before = snapshot(user_folder)
    code = main(["run", "product.yaml", "-o", ".", "--fidelity", "fast", "--no-report"])
    err = capsys.readouterr().err
    assert code == 2
    assert "current folder" in err and "Nothing was written" in err
    assert snapshot(user_folder) == before
    assert sorted(p.name for p in user_folder.iterdir()) == ["notes.txt", "product.yaml"]


def test_run_onto_an_existing_file_is_refused(user_folder, monkeypatch, capsys):
    monkeypatch.chdir(user_folder)
    before = snapshot(user_folder)
    code = main(["run", "product.yaml", "-o", "notes.txt", "--fidelity", "fast", "--no-report"])
    assert code == 2
    assert "notes.txt: is a file" in capsys.readouterr().err
    assert snapshot(user_folder) == before
    assert (user_folder / "notes.txt").is_file()


def test_run_into_a_foreign_folder_is_refused_naming_its_files(user_folder, capsys):
    code = main(["run", str(user_folder / "product.yaml"), "-o", str(user_folder),
                 "--fidelity", "fast", "--no-report"])
    err = capsys.readouterr().err
    assert code == 2
    assert "did not write" in err and "notes.txt" in err and "product.yaml" in err


def test_run_under_a_file_is_refused_before_any_work(user_folder, capsys):
    code = main(["run", str(user_folder / "product.yaml"), "-o", str(user_folder / "notes.txt" / "out"),
                 "--fidelity", "fast", "--no-report"])
    assert code == 2
    assert "is a file, not a folder" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["plan", "simulate"])
def test_plan_and_simulate_refuse_a_folder_or_a_foreign_file(user_folder, command, capsys):
    if command == "plan":
        argv = ["plan", str(user_folder / "product.yaml"), "-o"]
    else:  # a real plan to simulate, written by asmplan first
        plan_file = user_folder / "plan.json"
        assert main(["plan", str(user_folder / "product.yaml"), "-o", str(plan_file)]) == 0
        argv = ["simulate", str(plan_file), "--fidelity", "fast", "-o"]
    capsys.readouterr()
    before = snapshot(user_folder)
    assert main([*argv, str(user_folder)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert main([*argv, str(user_folder / "notes.txt")]) == 2
    assert "did not write" in capsys.readouterr().err
    assert snapshot(user_folder) == before


def test_an_asmplan_folder_is_replaced_and_one_with_a_foreign_file_is_not(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        atomic_write_text(stage / "report.html", "first")
        (stage / "img").mkdir()
        atomic_write_text(stage / "img" / "a.png", "png")
    marker = json.loads((out / OUTPUT_MARKER).read_text())
    assert marker["files"] == ["img/", "img/a.png", "report.html"]
    with staged_directory(out) as stage:
        atomic_write_text(stage / "report.html", "second")
    assert (out / "report.html").read_text() == "second"
    assert not (out / "img").exists()
    # the user drops a file of their own into asmplan's folder: now it is not ours to replace
    (out / "my-notes.txt").write_text("keep me")
    with pytest.raises(OutputPathError, match=r"holds files asmplan did not write \(my-notes.txt\)"):
        check_output_folder(out)
    assert (out / "my-notes.txt").read_text() == "keep me"


def test_an_empty_folder_may_be_used_and_nothing_is_left_beside_it(tmp_path):
    out = tmp_path / "empty"
    out.mkdir()
    with staged_directory(out) as stage:
        atomic_write_text(stage / "x.json", "{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty"]  # no staging, lock or old folder
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARKER, "x.json"]


def test_a_lock_held_by_an_exiting_process_is_waited_for(tmp_path):
    """A run killed with SIGKILL leaves its worker processes holding the folder's lock for the
    few ms until their parent-death signal has ended them: the next run waits for that (up to
    fileio.LOCK_WAIT_S), and is refused only when the holder keeps it."""
    import fcntl
    import threading
    import time

    from asmplan.fileio import LOCK_WAIT_S

    out = tmp_path / "out"
    fd = os.open(tmp_path / ".out.lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # an exiting process's lock
    threading.Timer(0.3, os.close, (fd,)).start()
    t0 = time.monotonic()
    with OutputFolder(out) as folder:
        waited = time.monotonic() - t0
        folder.commit()
    assert 0.3 <= waited < LOCK_WAIT_S
    held = os.open(tmp_path / ".out.lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)  # kept: refused after the wait
    try:
        with pytest.raises(OutputPathError, match="another asmplan process is writing"):
            OutputFolder(out)
    finally:
        os.close(held)


def test_a_second_writer_of_the_same_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    with OutputFolder(out) as first:
        with pytest.raises(OutputPathError, match="another asmplan process is writing"):
            OutputFolder(out)
        atomic_write_text(first.stage / "a.txt", "a")
        first.commit()
    with OutputFolder(out) as again:  # the lock is released with the first
        again.commit()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_foreign_files_that_arrive_during_the_work_stop_the_swap(tmp_path):
    out = tmp_path / "out"
    with OutputFolder(out) as folder:
        out.mkdir()
        (out / "theirs.txt").write_text("arrived while we simulated")
        with pytest.raises(OutputPathError, match="did not write"):
            folder.commit()
    assert (out / "theirs.txt").read_text() == "arrived while we simulated"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_the_swap_is_one_atomic_exchange(tmp_path, monkeypatch):
    """With RENAME_EXCHANGE the target is never absent: the previous folder is replaced by the
    exchange itself, not by a rename away and a rename in."""
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        atomic_write_text(stage / "v.txt", "1")
    renames: list[tuple[str, str]] = []
    real_replace = os.replace

    def watching_replace(a, b):
        if Path(b) == out:
            renames.append((str(a), str(b)))
        return real_replace(a, b)

    monkeypatch.setattr(fileio.os, "replace", watching_replace)
    with staged_directory(out) as stage:
        atomic_write_text(stage / "v.txt", "2")
    assert (out / "v.txt").read_text() == "2"
    assert renames == [], "the target was renamed into place instead of exchanged"


def test_a_previous_output_moved_aside_by_a_killed_run_is_put_back(tmp_path):
    """Where the file system cannot exchange, the swap is two renames; a run killed between
    them leaves the previous output in ``.out.old.PID.*/previous``: the next run restores it."""
    out = tmp_path / "out"
    dead_pid = 2**22 + 12345  # above pid_max: never a live process
    aside = tmp_path / f".out.old.{dead_pid}.x"
    (aside / "previous").mkdir(parents=True)
    (aside / "previous" / "report.html").write_text("previous")
    (aside / "previous" / OUTPUT_MARKER).write_text(
        json.dumps({"written_by": "asmplan-output-folder", "files": ["report.html"]}))
    stale_stage = tmp_path / f".out.staging.{dead_pid}.y"
    stale_stage.mkdir()
    with OutputFolder(out) as folder:
        assert (out / "report.html").read_text() == "previous"
        assert not aside.exists() and not stale_stage.exists()
        folder.commit()


def test_unwritable_place_is_refused_up_front(tmp_path, monkeypatch):
    # root may write anywhere, so emulate a read-only folder through os.access
    monkeypatch.setattr(fileio.os, "access", lambda path, mode: False)
    with pytest.raises(OutputPathError, match="no permission to write in"):
        check_output_folder(tmp_path / "out")
    with pytest.raises(OutputPathError, match="no permission to write in"):
        check_output_file(tmp_path / "plan.json")


def test_own_json_files_are_replaced_and_others_are_not(tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"format": "asmplan-plan", "version": 1}))
    assert check_output_file(plan, json_format="asmplan-plan") == plan
    with pytest.raises(OutputPathError, match="is not an asmplan asmplan-results file"):
        check_output_file(plan, json_format="asmplan-results")
    link = tmp_path / "link.json"
    link.symlink_to(plan)
    with pytest.raises(OutputPathError, match="symbolic link"):
        check_output_file(link)


def test_sweep_refuses_a_foreign_folder_and_marks_its_own(user_folder, capsys):
    before = snapshot(user_folder)
    assert main(["sweep", str(user_folder / "product.yaml"), "--samples", "1",
                 "-o", str(user_folder)]) == 2
    assert "did not write" in capsys.readouterr().err
    assert snapshot(user_folder) == before
