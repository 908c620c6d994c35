"""The independent producer's samples process (format conformance, not tuning)."""

import numpy as np
import pytest

from ldvsurvey.io.drivelog import load_bundle
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from tests.conftest import SAMPLES

CASES = [("rotating-imu-1d-ldv-8min", "tilt"), ("rotating-imu-1d-ldv-8min", "height"),
         ("rotating-imu-1d-ldv-8min", "calibrate"), ("fixed-imu-2d-ldv-8min", "calibrate"),
         ("fixed-imu-2d-ldv-8min", "height")]


@pytest.mark.parametrize("sample,pipeline", CASES)
def test_sample_processes(sample, pipeline):
    path = SAMPLES / f"{sample}.zip"
    if not path.exists():
        pytest.skip("shared/samples not beside the checkout")
    res = run_pipeline(get(pipeline), [load_bundle(path)], {})
    numbers = [v for v in res.summary.values() if isinstance(v, float)]
    assert numbers and all(np.isfinite(numbers))
    for cols in res.tables.values():
        assert len(next(iter(cols.values()))) > 100
