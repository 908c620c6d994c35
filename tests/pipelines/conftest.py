"""Simulated bundles for the pipeline tests, made once per session."""

import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate


@pytest.fixture(scope="session")
def height_sim():
    """The height paper's setup: gyro 0.002°/h, accel 50 µg, LDV 0.05 %, 100 Hz, 4-position scheme,
    20 km out-and-back with 35 m relief, 40 min."""
    sc = catalog.height(minutes=40.0, length_m=10000.0, relief_m=35.0)
    sim = simulate(sc, seed=11)
    files = bundle_files(sim)
    return sim, files, parse_files(files)


@pytest.fixture(scope="session")
def short_height_sim():
    sc = catalog.height(minutes=14.0, length_m=3500.0, relief_m=15.0, fix_schedule=[])
    return sc


@pytest.fixture(scope="session")
def gravity_sim():
    """The gravimetry paper's survey on the product's simulator (see catalog.gravity)."""
    sc = catalog.gravity()
    sim = simulate(sc, seed=4)
    files = bundle_files(sim)
    return sim, files, parse_files(files)
