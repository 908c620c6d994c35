"""The independent producer's sample bundles, which live outside the repository.

They are looked for in ``shared/samples`` beside the checkout, or in the folder named by
``LDVSURVEY_TEST_SAMPLES_DIR`` (an empty value, or a folder that does not exist, means none:
the tests that need them are skipped, saying so).
"""

import os
from pathlib import Path

import pytest

ENV = "LDVSURVEY_TEST_SAMPLES_DIR"
BESIDE_CHECKOUT = Path(__file__).resolve().parents[2].parent / "shared" / "samples"


def samples_dir() -> Path | None:
    """The samples folder, or None when there is none."""
    given = os.environ.get(ENV)
    d = Path(given) if given else (None if given == "" else BESIDE_CHECKOUT)
    return d if d is not None and d.is_dir() else None


def sample_zip(name: str) -> Path:
    """Path of ``<name>.zip`` among the samples; skips the calling test when it is not there."""
    d = samples_dir()
    if d is None:
        given = os.environ.get(ENV)
        where = f"{ENV} is empty" if given == "" else f"looked in {given or BESIDE_CHECKOUT}"
        pytest.skip(f"sample bundles not present ({where}; set {ENV} to their folder)")
    path = d / f"{name}.zip"
    if not path.is_file():
        pytest.skip(f"sample bundle {path} not present")
    return path
