"""Fidelity presets (sim/fidelity.py)."""

from __future__ import annotations

import dataclasses

import pytest

from asmplan.sim.fidelity import ACCURATE, BALANCED, FAST, Fidelity, preset


def test_presets_by_name_case_insensitive():
    assert preset("fast") is FAST
    assert preset("Balanced") is BALANCED
    assert preset(" ACCURATE ") is ACCURATE


def test_unknown_preset_lists_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown fidelity preset 'turbo'.*accurate.*balanced.*fast"):
        preset("turbo")


def test_presets_follow_the_field_notes():
    # dt <= 1/1000 s for fits <= 0.1 mm, contactSlop 1e-6 for tight fits.
    for fid in (BALANCED, ACCURATE):
        assert fid.dt_s <= 1e-3
        assert fid.contact_slop_m <= 1e-6
        assert fid.cone_friction  # PyBullet applies torsional friction only with the cone
        assert fid.collision_margin_m == 0.0
    # Cost and accuracy are ordered.
    assert FAST.dt_s > BALANCED.dt_s > ACCURATE.dt_s
    assert FAST.solver_iterations < BALANCED.solver_iterations < ACCURATE.solver_iterations
    assert (
        FAST.min_resolvable_clearance_m
        >= BALANCED.min_resolvable_clearance_m
        >= ACCURATE.min_resolvable_clearance_m
    )
    # The three presets ask for the three levels of detail.
    assert {f.geometry_lod for f in (FAST, BALANCED, ACCURATE)} == {"coarse", "convex", "exact"}


def test_invalid_settings_are_rejected_with_expected_and_found():
    with pytest.raises(ValueError, match=r"dt_s: expected a finite value > 0, found -0.001"):
        dataclasses.replace(BALANCED, dt_s=-0.001)
    with pytest.raises(ValueError, match=r"solver_iterations: expected an integer >= 1"):
        dataclasses.replace(BALANCED, solver_iterations=0)
    with pytest.raises(ValueError, match=r"geometry_lod: expected one of"):
        dataclasses.replace(BALANCED, geometry_lod="blobby")
    with pytest.raises(ValueError, match=r"contact_erp: expected a value in \[0, 1\]"):
        dataclasses.replace(BALANCED, contact_erp=1.5)
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'dt'"):
        dataclasses.replace(BALANCED, dt=0.1)


def test_replace_returns_a_new_validated_preset():
    custom = dataclasses.replace(BALANCED, name="custom", dt_s=1 / 2000)
    assert isinstance(custom, Fidelity)
    assert custom.dt_s == 1 / 2000
    assert BALANCED.dt_s == 1 / 1000
    assert custom.record_dt_s == pytest.approx(custom.record_every_steps / 2000)
