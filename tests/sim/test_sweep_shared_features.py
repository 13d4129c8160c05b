"""The sweep's size model draws one actual size per feature and sample: two mates that share a
feature (the pneumatic cylinder's front bore takes the piston, H9/f8, and seats the front cap,
H9/k8) see the same bore in every sample, and the geometry builds it once at that size. The
marginal distribution of each size is still the ISO zone model (normal, centred, 6 sigma = the
zone width, truncated to the zone)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from asmplan.knowledge import iso286
from asmplan.knowledge.loader import load_product
from asmplan.parts.geometry import fitted_sizes
from asmplan.sim import sweep as sw
from tests.conftest import example_path

BORE = "barrel.bore_front"
MATES = ("piston_in_barrel", "front_cap_in_barrel")


@pytest.fixture(scope="module")
def cylinder() -> tuple:
    product = load_product(example_path("pneumatic_cylinder"))
    ranges = {c.mate: c for c in sw.clearance_ranges(product)}
    assert all(ranges[m].hole_ref == BORE for m in MATES)  # the shared feature
    n = 4000
    samples = sw.draw_samples(sw.SweepSpec(n_samples=n, seed=7, vary=("clearance",)),
                              list(ranges.values()), {}, [])
    return product, ranges, samples


def test_two_mates_sharing_a_feature_see_the_same_drawn_size_in_every_sample(cylinder) -> None:
    product, ranges, samples = cylinder
    for s in samples:
        bore = s.size_deviation_m[BORE]
        for m in MATES:  # clearance = the shared bore minus this mate's own shaft
            pin = s.size_deviation_m[ranges[m].pin_ref]
            assert s.clearance_m[m] == pytest.approx(bore - pin, abs=1e-15)
    # the piston's clearance and the cap's differ only by their shafts: the bore is one size
    a = np.array([s.clearance_m[MATES[0]] + s.size_deviation_m[ranges[MATES[0]].pin_ref]
                  for s in samples])
    b = np.array([s.clearance_m[MATES[1]] + s.size_deviation_m[ranges[MATES[1]].pin_ref]
                  for s in samples])
    assert np.abs(a - b).max() < 1e-15
    # the geometry of a sample builds the bore once, at its drawn size, for both mates
    for s in samples[:20]:
        p2 = sw.perturb_product(product, s)
        sizing = fitted_sizes(p2)
        assert not sizing.notes  # no mate asks for another size of the bore
        nominal = product.feature("barrel", "bore_front").diameter_m
        D_built = sizing.diameters_m[("barrel", "bore_front")]
        assert D_built == pytest.approx(nominal + s.size_deviation_m[BORE], abs=1e-12)
        for m in MATES:
            mate = next(x for x in p2.mates if x.name == m)
            d = sizing.diameters_m[(mate.pin_part, mate.pin_feature)]
            assert D_built - d == pytest.approx(s.clearance_m[m], abs=1e-12)


def test_each_drawn_size_still_follows_its_iso_zone(cylinder) -> None:
    product, ranges, samples = cylinder
    n = len(samples)
    D = product.feature("barrel", "bore_front").diameter_m
    zones = {BORE: iso286.fit("H9/f8", D).hole,
             ranges["piston_in_barrel"].pin_ref: iso286.fit("H9/f8", D).shaft,
             ranges["front_cap_in_barrel"].pin_ref: iso286.fit("H9/k8", D).shaft}
    for ref, zone in zones.items():
        v = np.array([s.size_deviation_m[ref] for s in samples])
        lo, hi = zone.lower_m, zone.upper_m
        assert lo <= v.min() and v.max() <= hi
        mid, sigma = 0.5 * (lo + hi), (hi - lo) / 6.0
        # Kolmogorov-Smirnov against the normal truncated at +-3 sigma: the statistic within
        # the 1 % critical value 1.63 / sqrt(n) (2.6 % at n = 4000)
        ks = stats.kstest(v, stats.truncnorm(-3.0, 3.0, loc=mid, scale=sigma).cdf).statistic
        assert ks < 1.63 / math.sqrt(n), (ref, ks)
    # sizes of different features are independent: the correlation of the two shafts is noise
    r = np.corrcoef(
            [s.size_deviation_m[ranges["piston_in_barrel"].pin_ref] for s in samples],
            [s.size_deviation_m[ranges["front_cap_in_barrel"].pin_ref] for s in samples])[0, 1]
    assert abs(r) < 4 / math.sqrt(n)
    # and the two clearances sharing the bore are correlated as a shared size makes them:
    # corr = var(bore) / sqrt(var(c1) var(c2))
    c1 = np.array([s.clearance_m["piston_in_barrel"] for s in samples])
    c2 = np.array([s.clearance_m["front_cap_in_barrel"] for s in samples])
    widths = {k: z.upper_m - z.lower_m for k, z in zones.items()}
    vb = widths[BORE] ** 2
    expect = vb / math.sqrt((vb + widths[ranges["piston_in_barrel"].pin_ref] ** 2)
                            * (vb + widths[ranges["front_cap_in_barrel"].pin_ref] ** 2))
    assert np.corrcoef(c1, c2)[0, 1] == pytest.approx(expect, abs=4 / math.sqrt(n))


def test_the_size_deviations_survive_the_journal_round_trip(cylinder) -> None:
    import json

    _, _, samples = cylinder
    s = samples[3]
    assert sw.SampleParams.from_dict(json.loads(json.dumps(s.to_dict()))) == s
