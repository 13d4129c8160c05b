"""The example products load into the typed model in SI units; their graphs are sound."""

from __future__ import annotations

import json

import networkx as nx
import numpy as np
import pytest

from asmplan.cli import main
from asmplan.knowledge.errors import ProductError
from asmplan.knowledge.graphs import liaison_graph, precedence_graph
from asmplan.knowledge.loader import load_product
from asmplan.knowledge.yamlsource import parse_located
from tests.conftest import EXAMPLE_NAMES, example_path


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_examples_validate(name: str, capsys) -> None:
    assert main(["validate", str(example_path(name))]) == 0
    assert "valid product" in capsys.readouterr().out


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_precedence_graph_is_a_dag_with_an_origin_on_every_edge(examples, name: str) -> None:
    g = precedence_graph(examples[name])
    assert nx.is_directed_acyclic_graph(g)
    assert set(g.nodes) == set(examples[name].part_names)
    for u, v, data in g.edges(data=True):
        assert data["origins"], (u, v)
        for origin in data["origins"]:
            assert origin["kind"] in {"base", "rule"} and origin["reason"]


def test_rule_edges_carry_their_line_and_reason(examples) -> None:
    g = precedence_graph(examples["gear_unit"])
    origins = g.edges["bearing_block", "cover"]["origins"]
    rule = next(o for o in origins if o["kind"] == "rule")
    text = example_path("gear_unit").read_text().splitlines()
    assert "before: bearing_block, after: cover" in text[rule["line"] - 1]
    assert "screws" in rule["reason"]


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_liaison_graph_has_one_edge_per_mate(examples, name: str) -> None:
    product = examples[name]
    g = liaison_graph(product)
    assert g.number_of_edges() == len(product.mates)
    for mate in product.mates:
        data = g.edges[mate.pin_part, mate.hole_part, mate.name]
        assert data["fit"] == mate.fit
        assert data["clearance_min_m"] <= data["clearance_max_m"]
    assert nx.is_connected(g)  # every example is one connected product


def test_units_are_converted_once_to_si(examples) -> None:
    station = examples["pinhole_station"]
    part2 = station.part("part2")
    assert part2.T_product_part[2, 3] == pytest.approx(0.025)
    pin = part2.feature("p1")
    assert pin.diameter_m == pytest.approx(0.008) and pin.length_m == pytest.approx(0.008)
    np.testing.assert_allclose(pin.axis, [0, 0, -1])
    assert station.process.max_speed_m_s == pytest.approx(0.25)
    assert station.process.max_acceleration_m_s2 == pytest.approx(2.0)
    assert station.resources.gripper.mass_kg == pytest.approx(0.6)
    # 8 mm H7/g6: ISO 286 gives +5..+29 um diametral clearance
    mate = next(m for m in station.mates if m.name == "m21a")
    assert (mate.clearance_min_m, mate.clearance_max_m) == pytest.approx((5e-6, 29e-6))


def test_rotated_part_pose_in_radians(examples) -> None:
    shaft = examples["gear_unit"].part("shaft")
    # pitch -90 deg turns the shaft's local z onto world -x
    np.testing.assert_allclose(shaft.T_product_part[:3, :3] @ [0, 0, 1], [-1, 0, 0], atol=1e-12)


def test_same_input_same_graph_json(capsys) -> None:
    outs = []
    for _ in range(2):
        assert main(["graph", str(example_path("gear_unit"))]) == 0
        outs.append(capsys.readouterr().out)
    assert outs[0] == outs[1]
    data = json.loads(outs[0])
    assert {"liaison", "precedence"} <= set(data)


def test_dot_output_is_one_graph_with_the_geometry_precedences(capsys) -> None:
    assert main(["graph", str(example_path("pinhole_station")), "--format", "dot"]) == 0
    out = capsys.readouterr().out
    # one graph per call (Graphviz reads only the first graph of a file)
    assert out.startswith('digraph "pinhole_station precedence"') and out.count("graph ") == 1
    for name in ("part1", "part2", "part3", "part4"):
        assert f'"{name}"' in out
    # the precedences `asmplan sequence` derives from geometry are there, with their reasons
    assert '"part2" -> "part4"' in out and "geometry: with part4 in place part2 cannot" in out
    assert main(["graph", str(example_path("pinhole_station")), "--format", "dot",
                 "--knowledge-only"]) == 0
    assert "geometry:" not in capsys.readouterr().out
    assert main(["graph", str(example_path("pinhole_station")), "--format", "dot",
                 "--kind", "liaison"]) == 0
    assert capsys.readouterr().out.startswith('graph "pinhole_station liaison"')
    assert main(["graph", str(example_path("pinhole_station")), "--format", "dot",
                 "--kind", "both"]) == 2
    assert "one graph per call" in capsys.readouterr().err


def test_explicit_clearance_and_length_units(tmp_path) -> None:
    text = example_path("peg_in_hole").read_text().replace("fit: H7/g6", "clearance: {min: 0.01, max: 0.03}")
    text = text.replace("units: {length: mm, mass: g}", "units: {length: cm, mass: kg}")
    # the cell keeps its own unit (a product's unit never rescales the cell silently: a 60 cm
    # stroke is an input error, tests/knowledge/test_cell_units.py)
    text = text.replace("resources:\n", "resources:\n  units: {length: mm, mass: g}\n")
    doc = parse_located(text, "p.yaml")
    assert doc.data["mates"][0]["clearance"] == {"min": 0.01, "max": 0.03}
    path = tmp_path / "p.yaml"
    path.write_text(text)
    # in centimetres the file (written in mm) is ten times larger but inside the limits: a
    # 10 cm pin in a 10 cm hole with 0.1-0.3 mm clearance
    product = load_product(path)
    mate = product.mates[0]
    assert (mate.clearance_min_m, mate.clearance_max_m) == pytest.approx((1e-4, 3e-4), rel=1e-12)
    assert product.part("block").geometry.primitives[0].size_m == pytest.approx((0.6, 0.6, 0.3))
    # in metres, with the cell in the document's unit, its table is 600 m long: refused with the
    # limit, in the file's unit
    path.write_text(text.replace("length: cm", "length: m").replace("  units: {length: mm, mass: g}\n", ""))
    with pytest.raises(ProductError, match=r"p.yaml:28:18: resources.table.size\[0\]: expected a "
                       r"length within \+-100 m, found 600 m"):
        load_product(path)


@pytest.mark.parametrize("a", [(0, 0, 1), (1, 0, 0), (0, 1, 0), (1, 2, -3), (0, 0, -1)])
def test_rotation_between_turns_a_onto_b_also_for_opposite_vectors(a):
    """One rotate-a-onto-b for the whole project (frames, collision sweeps): a proper rotation
    that maps a onto b, including b = -a, where the axis must be found another way."""
    from asmplan.knowledge.frames import rotation_between

    a = np.asarray(a, float)
    u = a / np.linalg.norm(a)
    for b in (-a, a, np.array([0.3, -0.4, 0.5]), np.cross(a, [1.0, 2.0, 0.5])):
        R = rotation_between(a, b)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(R @ u, b / np.linalg.norm(b), atol=1e-12)


@pytest.mark.parametrize("axis", [(0, 0, 1), (1, 0, 0), (1, 2, -3)])
def test_rotation_about_turns_by_the_angle_and_keeps_the_axis(axis):
    """Rodrigues' rotation (the pose-error tilt): a proper rotation that keeps its axis, turns
    a perpendicular vector by exactly the angle, and agrees with rotation_between for it."""
    from asmplan.knowledge.frames import rotation_about, rotation_between

    k = np.asarray(axis, float) / np.linalg.norm(axis)
    p = np.cross(k, [0.3, -0.7, 0.2])
    p /= np.linalg.norm(p)
    for angle in (0.0, 0.01, 1.0, np.pi / 2, np.pi, -2.5):
        R = rotation_about(k, angle)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(R @ k, k, atol=1e-12)
        q = R @ p
        assert float(np.dot(p, q)) == pytest.approx(np.cos(angle), abs=1e-12)
        assert float(np.dot(np.cross(p, q), k)) == pytest.approx(np.sin(angle), abs=1e-12)
    # a quarter turn about k maps p onto k x p, as the shortest rotation from p to k x p does
    np.testing.assert_allclose(rotation_about(k, np.pi / 2) @ p,
                               rotation_between(p, np.cross(k, p)) @ p, atol=1e-12)


def test_readonly_array_checks_shape_and_finiteness_and_freezes_a_copy():
    from asmplan.knowledge.arrays import readonly_array

    src = np.array([1.0, 2.0, 3.0])
    a = readonly_array(src, (3,), "v", finite=True)
    src[0] = 9.0
    assert a.tolist() == [1.0, 2.0, 3.0] and not a.flags.writeable
    with pytest.raises(ValueError):
        a[0] = 0.0
    with pytest.raises(ValueError, match=r"v: expected shape \(3,\), found \(2,\)"):
        readonly_array([1, 2], (3,), "v")
    with pytest.raises(ValueError, match=r"v: expected finite numbers, found \[1.0, nan\]"):
        readonly_array([1.0, float("nan")], None, "v", finite=True)
    with pytest.raises(ValueError, match=r"T: expected finite numbers, found 1 NaN or inf entries"):
        readonly_array(np.r_[np.zeros(99), np.inf], None, "T", finite=True)
    assert readonly_array([1.0, float("nan")]).shape == (2,)  # finite only when asked
    assert readonly_array([True, False], dtype=None).dtype == bool  # dtype kept when None
