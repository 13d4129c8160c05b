"""The equal-accuracy table of the peer comparison (bench/peer_ladder.py): which step matches,
the cost ratio, and the report's wording (no simulation: figures given)."""

from __future__ import annotations

import pytest

from bench.peer_ladder import LadderStep, PeerMatch, format_peer_matches, jam_bound_m


def _match(errors_mm: tuple[float, ...], costs: tuple[float, ...]) -> PeerMatch:
    dts = (1e-4, 5e-5, 2e-5, 1e-5)
    return PeerMatch(0.1e-3, 5.0, 1.584e-3, jam_bound_m("balanced"), 0.0, 0.4,
                     tuple(LadderStep(dt, e * 1e-3, c)
                           for dt, e, c in zip(dts, errors_mm, costs, strict=True)))


def test_the_coarsest_step_within_balanceds_bound_is_the_match_and_sets_the_ratio() -> None:
    m = _match((0.0396, 0.0184, 0.0069, 0.0034), (0.18, 0.35, 0.86, 1.72))
    assert jam_bound_m("balanced") == pytest.approx(0.01e-3)
    assert m.match is not None and m.match.dt_s == 2e-5
    assert m.cost_ratio == pytest.approx(0.86 / 0.4)
    text = format_peer_matches([m], "balanced")
    assert "| at 0.02 ms | 2.1x |" in text
    assert "+0.0069 mm, 0.86" in text


def test_a_peer_never_within_the_bound_is_said_so() -> None:
    m = _match((0.09, 0.09, 0.08, 0.08), (0.18, 0.35, 0.86, 1.72))
    assert m.match is None and m.cost_ratio is None
    assert "| not down to 0.01 ms | - |" in format_peer_matches([m], "balanced")
    assert format_peer_matches([], "balanced") == ""


def test_the_report_prints_the_equal_accuracy_table_after_the_peer_table() -> None:
    import bench.suite as b
    from bench.accuracy import PeerRow

    row = PeerRow("Whitney jam depth, c = 0.1 mm, t = 5 deg", "l* = 1.584 mm", "m", 0.0,
                  0.5e-3, 0.4, 0.03)
    acc = b.AccuracyResult((), (), 1 / 16000, None, (row,),
                           (_match((0.0396, 0.0184, 0.0069, 0.0034), (0.18, 0.35, 0.86, 1.72)),))
    text = b.format_markdown(b.BenchReport(quick=False, machine={}, accuracy=acc))
    assert text.index("## PyBullet and MuJoCo side by side") < text.index(
        "### The jam scenes at equal accuracy") < text.index("| at 0.02 ms | 2.1x |")
    assert "CPU s / sim s" in text
