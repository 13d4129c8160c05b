"""Atomic output: files and folders appear whole or not at all."""

from __future__ import annotations

import os
import stat

import pytest

from asmplan.fileio import atomic_write_json, atomic_write_text, dumps_json, staged_directory


def test_atomic_write_replaces_whole_and_leaves_no_temp(tmp_path) -> None:
    target = tmp_path / "a.txt"
    atomic_write_text(target, "old")
    atomic_write_text(target, "new contents")
    assert target.read_text() == "new contents"
    assert os.listdir(tmp_path) == ["a.txt"]
    mode = stat.S_IMODE(target.stat().st_mode)
    assert mode & stat.S_IRGRP, f"expected group-readable, found {oct(mode)}"


def test_json_is_deterministic_and_rejects_nan(tmp_path) -> None:
    assert dumps_json({"b": 1, "a": [1.5, None]}) == dumps_json({"a": [1.5, None], "b": 1})
    with pytest.raises(ValueError):
        atomic_write_json(tmp_path / "x.json", {"x": float("nan")})
    assert not list(tmp_path.iterdir())


def test_staged_directory_keeps_previous_on_failure(tmp_path) -> None:
    out = tmp_path / "out"
    with staged_directory(out) as stage:
        atomic_write_text(stage / "report.html", "first")
    with pytest.raises(KeyboardInterrupt), staged_directory(out) as stage:
        atomic_write_text(stage / "report.html", "half")
        raise KeyboardInterrupt
    assert (out / "report.html").read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    with staged_directory(out) as stage:
        atomic_write_text(stage / "report.html", "second")
    assert (out / "report.html").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
