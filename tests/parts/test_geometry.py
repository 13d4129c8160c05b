"""Solids from the product model: fitted sizes, exact meshes, mass properties (parts/geometry.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.parts.collision import CollisionWorld
from asmplan.parts.geometry import (
    GeometrySettings,
    fitted_sizes,
    manifold_to_trimesh,
    mass_properties,
    part_shape,
    shape_solid,
    sides_for_tolerance,
)
from asmplan.parts.models import ProductGeometry
from asmplan.parts.pieces import CollisionModel, ConvexPiece

TOL = GeometrySettings().exact_tolerance_m
STEEL, ALU = 7850.0, 2700.0


def test_fitted_sizes_put_each_zone_at_its_middle(examples):
    # H7/g6 at 8 mm: hole 0..+15 um, pin -5..-14 um (ISO 286-2); clearance 5..29 um
    sizing = fitted_sizes(examples["pinhole_station"])
    hole = sizing.diameters_m[("part1", "h1")]
    pin = sizing.diameters_m[("part2", "p1")]
    assert hole == pytest.approx(8e-3 + 7.5e-6, abs=1e-12)
    assert pin == pytest.approx(8e-3 - 9.5e-6, abs=1e-12)
    assert hole - pin == pytest.approx(17e-6, abs=1e-12)
    assert sizing.radial_clearance_m[("part1", "h1")] == pytest.approx(8.5e-6, abs=1e-12)


def test_explicit_clearance_is_split_between_hole_and_pin(make_product):
    p = make_product("""
        parts:
          - {name: a, material: steel, pose: {xyz: [0, 0, 0]},
             geometry: {type: box, size: [20, 20, 10], holes: [{name: h, at: [0, 0, 5], diameter: 6, depth: 8}]}}
          - {name: b, material: steel, pose: {xyz: [0, 0, 20]}, start: {xyz: [50, 0, 5]},
             geometry: {type: box, size: [10, 10, 10], pins: [{name: p, at: [0, 0, -5], axis: [0, 0, -1], diameter: 6, length: 5}]}}
        mates:
          - {pin: b.p, hole: a.h, clearance: {min: 0.02, max: 0.06}}
    """)
    s = fitted_sizes(p)
    assert s.diameters_m[("a", "h")] - s.diameters_m[("b", "p")] == pytest.approx(40e-6, abs=1e-12)
    assert s.diameters_m[("a", "h")] == pytest.approx(6e-3 + 20e-6, abs=1e-12)


def test_stepped_shaft_takes_each_fit_and_chamfers_its_ends(examples):
    product = examples["gear_unit"]
    shape = part_shape(product.part("shaft"), fitted_sizes(product))
    (body,) = shape.bodies
    got = [(round(s.z0_m * 1e3, 6), round(s.z1_m * 1e3, 6), round(2e6 * s.radius_m, 3)) for s in body.sections]
    # hub h6 (0..-9 um), plain, front g6 (-5..-14 um), tail c11 (-80..-170 um) at 10 mm
    assert got == [(-40, -30, 9995.5), (-30, -10, 10000.0), (-10, 30, 9990.5), (30, 40, 9875.0)]
    assert body.chamfer_low_m == pytest.approx(0.5e-3)
    assert body.chamfer_high_m == pytest.approx(0.5e-3)


def _one_part(make_product, geometry: str, material: str = "steel"):
    p = make_product(f"""
        parts:
          - {{name: x, material: {material}, pose: {{xyz: [0, 0, 0]}}, geometry: {geometry}}}
    """)
    part = p.part("x")
    mesh = manifold_to_trimesh(shape_solid(part_shape(part), TOL))
    return part, mesh, mass_properties(part, mesh)


def test_box_mass_properties_are_analytic(make_product):
    _part, mesh, mp = _one_part(make_product, "{type: box, size: [60, 40, 20]}")
    a, b, c = 0.06, 0.04, 0.02
    m = STEEL * a * b * c
    assert mesh.is_watertight
    assert mp.mass_kg == pytest.approx(m, rel=1e-12)
    np.testing.assert_allclose(mp.com_m, 0.0, atol=1e-15)
    expected = m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(mp.inertia_kgm2, expected, rtol=1e-9, atol=1e-18)


def test_cylinder_mass_properties_within_the_polygon_bound(make_product):
    _part, _mesh, mp = _one_part(make_product, "{type: cylinder, diameter: 20, length: 50}", "aluminium")
    r, L = 0.01, 0.05
    m = ALU * math.pi * r * r * L
    # circumscribed polygon, radial error <= 1 um: relative mass error <= 2 * 1e-6 / r = 2e-4
    rel = 2 * TOL / r
    assert m <= mp.mass_kg <= m * (1 + rel)
    assert mp.inertia_kgm2[2, 2] == pytest.approx(m * r * r / 2, rel=2 * rel)
    assert mp.inertia_kgm2[0, 0] == pytest.approx(m * (3 * r * r + L * L) / 12, rel=2 * rel)


def test_box_minus_blind_hole_mass_properties(make_product):
    _part, _mesh, mp = _one_part(
        make_product, "{type: box, size: [60, 60, 30], holes: [{name: h, at: [0, 0, 15], diameter: 10, depth: 20}]}")
    a, c, r, d = 0.06, 0.03, 0.005, 0.02
    v_box, v_hole = a * a * c, math.pi * r * r * d
    z_hole = c / 2 - d / 2
    m = STEEL * (v_box - v_hole)
    com_z = -STEEL * v_hole * z_hole / m
    # the hole's polygon has its faces tangent to the circle: it is at most 2 pi r * 1 um * d larger
    dv = 2 * math.pi * r * TOL * d
    assert m - STEEL * dv <= mp.mass_kg <= m
    assert mp.com_m[2] == pytest.approx(com_z, abs=1e-6)
    np.testing.assert_allclose(mp.com_m[:2], 0.0, atol=1e-9)
    # Izz: box minus the hole's cylinder (on axis)
    izz = STEEL * v_box * (a * a + a * a) / 12 - STEEL * v_hole * r * r / 2
    assert mp.inertia_kgm2[2, 2] == pytest.approx(izz, rel=1e-4)


def test_given_mass_overrides_the_material(make_product):
    p = make_product("""
        parts:
          - {name: x, mass: 250, pose: {xyz: [0, 0, 0]}, geometry: {type: box, size: [10, 20, 30]}}
    """)
    mp = ProductGeometry(p).mass_properties("x")
    assert mp.mass_kg == pytest.approx(0.25)
    assert mp.density_kg_m3 == pytest.approx(0.25 / 6e-6)
    assert mp.source == "given mass"


@pytest.mark.parametrize("diameter_mm", [3.0, 10.0, 40.0])
def test_a_hole_is_never_narrower_than_declared(make_product, diameter_mm):
    p = make_product(f"""
        parts:
          - {{name: x, material: steel, pose: {{xyz: [0, 0, 0]}},
             geometry: {{type: box, size: [60, 60, 30], holes: [{{name: h, at: [0, 0, 15], diameter: {diameter_mm}, through: true}}]}}}}
    """)
    g = ProductGeometry(p)
    model = g.collision_model("x", "exact")
    r = diameter_mm / 2e3
    world = CollisionWorld()
    world.add("x", model, np.eye(4))
    # a coaxial cylinder 20 nm narrower than the hole is 10 nm from the walls everywhere
    probe = CollisionModel("exact", (ConvexPiece(kind="cylinder", T_part_piece=np.eye(4),
                                                 radius_m=r - 10e-9, length_m=0.02),))
    world.add("probe", probe, np.eye(4))
    assert world.distance("probe", "x") == pytest.approx(10e-9, abs=2e-9)
    # the polygon's corners are at most the exact tolerance beyond the circle
    mesh = g.mesh("x")
    rho = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])
    wall = rho[rho < 1.5 * r]
    assert wall.min() >= r - 1e-12
    assert wall.max() <= r + TOL
    assert sides_for_tolerance(r, TOL) >= 64


def test_every_example_part_is_one_watertight_solid(examples):
    for product in examples.values():
        g = ProductGeometry(product)
        for name in product.part_names:
            mesh = g.mesh(name).to_trimesh()
            assert mesh.is_watertight, name
            assert mesh.body_count == 1, name
            assert g.mass_properties(name).mass_kg > 0
