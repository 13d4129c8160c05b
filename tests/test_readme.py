"""The README's Python example runs as written."""

from __future__ import annotations

import os
import re

import pytest

from tests.conftest import REPO


@pytest.mark.slow
def test_readme_python_example_runs(tmp_path) -> None:
    text = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "the README has no python example"
    (tmp_path / "examples").symlink_to(REPO / "examples")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        for block in blocks:
            exec(compile(block, "README.md", "exec"), {"__name__": "readme"})
    finally:
        os.chdir(cwd)
    assert (tmp_path / "assembled.png").stat().st_size > 1000
    assert (tmp_path / "out" / "station-fast" / "report.html").is_file()
