"""GNSS outages on an INS/GNSS drive without an LDV: the forward filter's position error against the
simulator's truth stays within 3× its own 1-σ through 10, 30 and 60 s outages, for a navigation-grade
and a tactical-grade IMU, and that 1-σ grows through the outage (the INS bridges it; the figures of
docs/accuracy.md come from benchmarks/bench_outages.py)."""

import pytest

from tests.pipelines.outages import run_outages


@pytest.mark.parametrize("grade", ["navigation", "tactical"])
def test_outage_errors_within_three_sigma(grade):
    out, _, _ = run_outages([10.0, 30.0, 60.0], grade=grade, smooth=False, seed=2)
    for o in out:
        assert o.horizontal_m <= 3.0 * o.horizontal_sigma_m, o
        assert abs(o.vertical_m) <= 3.0 * o.vertical_sigma_m, o
    sig = [o.horizontal_sigma_m for o in out]
    assert sig[0] < sig[1] < sig[2], sig  # the filter knows the outage grows its uncertainty
    if grade == "tactical":  # a tactical IMU drifts metres in a minute without GNSS: a real outage
        assert out[2].horizontal_m > 0.3
