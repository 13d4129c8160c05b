"""BulletWorld (sim/bullet.py): bodies from convex pieces, contacts, state, cleanliness."""

from __future__ import annotations

import math

import numpy as np
import pytest

from asmplan.parts.decompose import HoleSpec, block_with_holes_pieces
from asmplan.parts.pieces import ConvexPiece
from asmplan.sim.bullet import BulletError, BulletWorld
from asmplan.sim.fidelity import BALANCED
from bench.scenarios import box_inertia, box_piece

G = 9.81


def cube_hull(centre, half):
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    T = np.eye(4)
    T[:3, 3] = centre
    return ConvexPiece(kind="hull", T_part_piece=T, vertices_m=v)


def test_world_owns_and_releases_its_client():
    with BulletWorld(BALANCED) as world:
        cid = world.client_id
        assert cid >= 0
    with pytest.raises(BulletError, match="closed"):
        world.client_id  # noqa: B018
    # two worlds at once have distinct clients
    with BulletWorld(BALANCED) as a, BulletWorld(BALANCED) as b:
        assert a.client_id != b.client_id


@pytest.mark.parametrize("kind", ["box", "hull"])
def test_more_than_16_pieces_are_all_kept(kind):
    """A 20-piece column rests on its LAST piece: a dropped 17th+ child would sink it."""
    n, half = 20, 0.004
    pieces = []
    for i in range(n):
        z = (n - 1 - i) * 2 * half  # piece 0 on top, piece 19 at the bottom
        if kind == "box":
            T = np.eye(4)
            T[2, 3] = z
            pieces.append(ConvexPiece(kind="box", T_part_piece=T, half_extents_m=[half] * 3))
        else:
            pieces.append(cube_hull((0.0, 0.0, z), half))
    height = n * 2 * half
    mass = 0.05
    inertia = box_inertia(mass, (2 * half, 2 * half, height))
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        T = np.eye(4)
        T[2, 3] = half + 1e-4
        body = world.add_body(pieces, mass, T, com_m=(0, 0, height / 2 - half), inertia_kgm2=inertia)
        world.step(500)
        z_bottom = world.pose(body)[2, 3] - half
        assert abs(z_bottom) < 5e-6  # exact hull margins: rests on the ground within 5 um


def test_hull_block_hole_lets_a_sphere_through_to_the_floor():
    r_hole = 0.003
    pieces = block_with_holes_pieces((0.03, 0.03, 0.02), (HoleSpec((0.0, 0.0), r_hole, None, 8),))
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        T = np.eye(4)
        T[2, 3] = 0.01
        world.add_body(pieces, 0.0, T, name="block")
        r_ball = r_hole - 0.1e-3  # 0.1 mm radial clearance
        ball = ConvexPiece(kind="sphere", T_part_piece=np.eye(4), radius_m=r_ball)
        Tb = np.eye(4)
        Tb[2, 3] = 0.03
        m = 0.001
        b = world.add_body((ball,), m, Tb, inertia_kgm2=np.eye(3) * 0.4 * m * r_ball**2)
        world.step(600)
        assert world.pose(b)[2, 3] == pytest.approx(r_ball, abs=5e-6)  # on the floor


def test_centre_of_mass_and_inertia_are_exact():
    """Zero gravity: a force through the COM gives no rotation; a torque gives alpha = tau / I."""
    size = (0.1, 0.04, 0.02)
    mass = 0.3
    inertia = box_inertia(mass, size)
    com = np.array([0.02, 0.0, 0.0])
    # spheres stay primitives (boxes become hulls): 16 of them -> base (hulls) + one link
    tiny = ConvexPiece(kind="sphere", T_part_piece=np.eye(4), radius_m=0.001)
    pieces = (box_piece(size), *([tiny] * 16))
    with BulletWorld(BALANCED, gravity_mps2=(0, 0, 0)) as world:
        body = world.add_body(pieces, mass, np.eye(4), com_m=com, inertia_kgm2=inertia)
        assert world.body_link_count(body) == 1
        assert world.body_mass_kg(body) == pytest.approx(mass)
        F = 0.3
        for _ in range(100):
            world.apply_force(body, -1, (0, F, 0), world.com_position_m(body))
            world.step()
        v, w = world.velocity(body)
        t = 100 * BALANCED.dt_s
        assert v[1] == pytest.approx(F / mass * t, rel=1e-6)
        assert np.linalg.norm(w) < 1e-9
        world.set_velocity(body, (0, 0, 0), (0, 0, 0))
        # a couple of two forces: torque about z = F * d
        d = 0.05
        for _ in range(100):
            p = world.com_position_m(body)
            world.apply_force(body, -1, (0, F, 0), p + np.array([d / 2, 0, 0]))
            world.apply_force(body, -1, (0, -F, 0), p - np.array([d / 2, 0, 0]))
            world.step()
        _, w = world.velocity(body)
        assert w[2] == pytest.approx(F * d / inertia[2, 2] * t, rel=2e-3)


def _boxp(centre, half, R=None):
    T = np.eye(4)
    T[:3, 3] = centre
    if R is not None:
        T[:3, :3] = R
    return ConvexPiece(kind="box", T_part_piece=T, half_extents_m=[half] * 3)


_H = 0.01
_OCTANTS = [(x, y, z) for x in (-_H / 2, _H / 2) for y in (-_H / 2, _H / 2) for z in (-_H / 2, _H / 2)]
PART_KINDS = {  # plain shapes and every kind of compound this module builds
    "box": (_boxp((0, 0, 0), _H),),
    "box_rotated": (_boxp((0, 0, 0), _H, np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])),),
    "8_boxes": tuple(_boxp(c, _H / 2) for c in _OCTANTS),
    "hull": (cube_hull((0, 0, 0), _H),),
    "8_hulls": tuple(cube_hull(c, _H / 2) for c in _OCTANTS),
}
_SLAB_HULL = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.2, 0.2) for z in (-0.01, 0.01)])
SLAB_KINDS = {
    "box": (ConvexPiece(kind="box", T_part_piece=np.eye(4), half_extents_m=[0.2, 0.2, 0.01]),),
    "2_hulls": tuple(
        ConvexPiece(kind="hull", T_part_piece=np.eye(4), vertices_m=_SLAB_HULL + np.array([dx, 0.0, 0.0]))
        for dx in (-0.1, 0.1)
    ),
}


@pytest.mark.parametrize("part_first", [True, False])
@pytest.mark.parametrize("slab_kind", sorted(SLAB_KINDS))
@pytest.mark.parametrize("part_kind", sorted(PART_KINDS))
def test_contact_forces_balance_the_weight_on_a_slope(part_kind, slab_kind, part_first):
    """Static cube on a 20 deg slope: normal + friction on it sum to exactly -m g.

    PyBullet reports friction in its contact manifold's order, which depends on creation
    order and on which collider is a compound; every combination must come out right.
    """
    ang = math.radians(20)
    R = np.array([[1, 0, 0], [0, math.cos(ang), -math.sin(ang)], [0, math.sin(ang), math.cos(ang)]])
    mass = 0.1
    T_slab = np.eye(4)
    T_slab[:3, :3] = R
    T_slab[:3, 3] = R @ [0, 0, -0.01]
    T_box = np.eye(4)
    T_box[:3, :3] = R
    T_box[:3, 3] = R @ [0, 0, _H + 1e-5]
    with BulletWorld(BALANCED) as world:

        def add_part():
            inertia = box_inertia(mass, (2 * _H,) * 3)
            return world.add_body(PART_KINDS[part_kind], mass, T_box, inertia_kgm2=inertia, friction=1.0)

        def add_slab():
            return world.add_body(SLAB_KINDS[slab_kind], 0.0, T_slab, friction=1.0)

        if part_first:
            part, slope = add_part(), add_slab()
        else:
            slope, part = add_slab(), add_part()
        world.step(600)
        on_part = world.contacts(part, slope).force_on_a_N()
        on_slope = world.contacts(slope, part).force_on_a_N()
        weight = np.array([0, 0, -mass * G])
        # 2 % tolerance: resting hulls creep at ~1e-5 m/s and PyBullet's reported forces then
        # miss ~1 % of the applied impulse; a wrong friction sign is off by 64 %.
        assert np.allclose(on_part, -weight, atol=2e-2 * mass * G)
        assert np.allclose(on_slope, weight, atol=2e-2 * mass * G)
        # the friction is not zero: it carries m g sin(20 deg)
        friction = world.contacts(part, slope).friction_on_a_N.sum(axis=0)
        assert np.linalg.norm(friction) == pytest.approx(mass * G * math.sin(ang), rel=3e-2)


def test_save_and_restore_replays_exactly():
    with BulletWorld(BALANCED) as world:
        world.add_ground()
        T = np.eye(4)
        T[2, 3] = 0.05
        T[:3, :3] = np.array([[0.8, -0.6, 0], [0.6, 0.8, 0], [0, 0, 1]])
        body = world.add_body((box_piece((0.02, 0.03, 0.04)),), 0.1, T, inertia_kgm2=box_inertia(0.1, (0.02, 0.03, 0.04)))
        world.set_velocity(body, (0.1, 0, 0), (1.0, 2.0, 0.5))
        world.step(50)
        sid = world.save_state()
        t_saved = world.time_s
        world.step(300)
        first = world.pose(body)
        world.restore_state(sid)
        assert world.time_s == t_saved
        world.step(300)
        assert np.allclose(world.pose(body), first, atol=1e-9)
        world.remove_state(sid)
        with pytest.raises(KeyError, match="unknown state"):
            world.restore_state(sid)


def test_pose_is_the_part_frame_not_the_com_frame():
    size = (0.04, 0.02, 0.02)
    T = np.eye(4)
    T[:3, :3] = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    T[:3, 3] = [0.1, 0.2, 0.3]
    inertia = box_inertia(0.2, size) + np.array([[0, 1e-6, 0], [1e-6, 0, 0], [0, 0, 0]])
    with BulletWorld(BALANCED, gravity_mps2=(0, 0, 0)) as world:
        body = world.add_body((box_piece(size),), 0.2, T, com_m=(0.01, 0.002, -0.003), inertia_kgm2=inertia)
        assert np.allclose(world.pose(body), T, atol=1e-12)
        T2 = T.copy()
        T2[:3, 3] += [0.01, 0, 0]
        world.set_pose(body, T2)
        assert np.allclose(world.pose(body), T2, atol=1e-12)


def test_bad_bodies_are_rejected():
    with BulletWorld(BALANCED) as world:
        with pytest.raises(ValueError, match="inertia_kgm2 is required"):
            world.add_body((box_piece((0.01,) * 3),), 0.1, np.eye(4))
        with pytest.raises(ValueError, match="positive definite"):
            world.add_body((box_piece((0.01,) * 3),), 0.1, np.eye(4), inertia_kgm2=np.zeros((3, 3)))
        with pytest.raises(ValueError, match="at least one piece"):
            world.add_body((), 0.0, np.eye(4))


def _ring_of_hulls(n=12, r_in=0.005, r_out=0.010, half_length=0.004):
    """A collar-like ring: n convex sectors (hulls) about the z axis."""
    pieces = []
    for k in range(n):
        a0, a1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n
        v = [[r * math.cos(a), r * math.sin(a), z] for r in (r_in / math.cos(math.pi / n), r_out)
             for a in (a0, a1) for z in (-half_length, half_length)]
        pieces.append(ConvexPiece(kind="hull", T_part_piece=np.eye(4), vertices_m=np.array(v)))
    return pieces


def _offset_box():
    T = np.eye(4)
    T[:3, 3] = (0.01, 0.0, 0.0)
    return [ConvexPiece(kind="box", T_part_piece=T, half_extents_m=[0.01, 0.005, 0.002])]


def _measured_breaking_m(pieces, inertia, limit_m=None):
    """Largest gap (m) between the body's lowest point and a static hull slab at which Bullet
    still reports a contact point after one collision pass (bisection to 1 nm)."""
    import pybullet

    slab = cube_hull((0.0, 0.0, -0.5), 0.5)
    lowest = min(float((pc.T_part_piece[:3, :3] @ np.asarray(pc.vertices_m).T)[2].min())
                 if pc.kind == "hull" else
                 float(pc.T_part_piece[2, 3] - pc.half_extents_m[2]) for pc in pieces)

    def touches(gap):
        with BulletWorld(BALANCED) as world:
            ground = world.add_body([slab], 0.0, np.eye(4))
            T = np.eye(4)
            T[2, 3] = gap - lowest
            body = world.add_body(pieces, 0.01, T, inertia_kgm2=inertia)
            if limit_m is not None:
                world.limit_contact_breaking_m(body, limit_m)
            expected = world.contact_breaking_m(body)
            pybullet.performCollisionDetection(physicsClientId=world.client_id)
            return world.contacts(body, ground).count > 0, expected

    lo, hi = 0.0, 5e-3
    expected = touches(0.0)[1]
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if touches(mid)[0] else (lo, mid)
    return lo, expected


@pytest.mark.parametrize("shape", ["hull ring", "box off the centre of mass", "rotated axes"])
def test_contact_breaking_distance_is_known_and_can_be_limited(shape):
    # Bullet creates and keeps a contact point up to fraction x bounding radius; at PyBullet's
    # default 0.02 that is 0.36 mm for a 20 mm ring of hulls (measured 360.3 um), more than a
    # loose fit's gap. contact_breaking_m must predict the measured distance, and
    # limit_contact_breaking_m must bring it down to the limit.
    if shape == "hull ring":
        pieces, inertia = _ring_of_hulls(), np.diag([1e-6, 1e-6, 2e-6])
    else:
        pieces, inertia = _offset_box(), np.diag([1e-6, 3e-6, 5e-6])
        if shape == "rotated axes":  # principal axes 29 deg off the body frame's
            c, s = math.cos(0.5), math.sin(0.5)
            R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            inertia = R @ inertia @ R.T
    # In millimetre units (Fidelity.bullet_units_per_m) Bullet stops the distance growing at a
    # radius of 2 units: fraction x 2 mm + 2 um of margins (PyBullet's 0.02: 42 um, measured
    # 42.0 um for a 20 mm hull cube). BALANCED's fraction makes it half its smallest
    # resolvable clearance, 25 um. The prediction is an upper bound.
    measured, expected = _measured_breaking_m(pieces, inertia)
    assert expected == pytest.approx(25e-6, rel=1e-9)
    assert 0.0 < measured <= expected * (1 + 1e-3)
    measured, expected = _measured_breaking_m(pieces, inertia, limit_m=8e-6)
    assert expected == pytest.approx(8e-6, rel=1e-12)
    assert measured <= 8e-6 * (1 + 1e-3)


def test_contact_breaking_limit_is_checked():
    with BulletWorld(BALANCED) as world:
        body = world.add_body([cube_hull((0.0, 0.0, 0.0), 0.01)], 0.0, np.eye(4))
        with pytest.raises(ValueError, match=r"distance_m: expected a finite value > 0, found 0"):
            world.limit_contact_breaking_m(body, 0.0)
        world.limit_contact_breaking_m(body, 1.0)  # above the default: unchanged
        assert world.contact_breaking_m(body) == pytest.approx(25e-6)
        world.step()
        with pytest.raises(BulletError, match=r"expected before the first step, found 1 steps"):
            world.limit_contact_breaking_m(body, 1e-5)
