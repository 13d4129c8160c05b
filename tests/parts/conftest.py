"""Helpers for the parts tests: small products written on the fly and the parts fixtures."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from asmplan.knowledge.loader import load_product
from asmplan.knowledge.model import Product

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "parts"

RESOURCES = """
resources:
  gripper: {stroke: 60, finger: {size: [16, 8, 25], friction: 1.0}, max_force: 60}
  table: {size: [600, 400, 40]}
"""


@pytest.fixture
def make_product(tmp_path: Path):
    """``make_product(yaml_body)`` -> Product, for a body holding ``parts:`` (and ``mates:``)."""

    def make(body: str, name: str = "p", *, consistency: bool = True) -> Product:
        text = f"asmplan: 1\nproduct: {name}\nunits: {{length: mm, mass: g}}\n" \
               f"{textwrap.dedent(body)}\n{RESOURCES}"
        path = tmp_path / f"{name}.yaml"
        path.write_text(text, encoding="utf-8")
        return load_product(path, consistency=consistency)

    return make
