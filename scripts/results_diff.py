"""Record every pipeline's results on fixed simulated drives, or compare them with a recording.

A refactor that must not change a number (issue 30: "results bit-identical, or within 1e-12
relative where the order of operations must change") is checked with this script: record on the
commit before, compare on the commit after. The drives are the robustness matrix's (``ideal`` and
``all`` effects on the rotating-IMU height drive through tilt, calibrate, height, navigate and dov),
its gravity and damping cases, a drive without an LDV (navigate, gravity, dov) and a two-day
gravity network with base ties. Every numeric value of every summary and table is compared;
timings, dates and software versions are skipped.

Run (about 3 minutes):
    PYTHONPATH=backend .venv/bin/python scripts/results_diff.py record /tmp/before
    PYTHONPATH=backend .venv/bin/python scripts/results_diff.py compare /tmp/before [--rtol 1e-12]
"""

from __future__ import annotations

import argparse
import pathlib
import pickle
import re
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ldvsurvey.io.drivelog import parse_files  # noqa: E402
from ldvsurvey.nav.earth import MGAL, normal_gravity  # noqa: E402
from ldvsurvey.pipelines.base import run_pipeline  # noqa: E402
from ldvsurvey.pipelines.registry import get  # noqa: E402
from ldvsurvey.sim import catalog, survey  # noqa: E402
from ldvsurvey.sim.scenario import bundle_files, simulate  # noqa: E402
from tests.robustness.matrix import run_height_case  # noqa: E402
from tests.robustness.matrix_gd import run_damping_case, run_gravity_case  # noqa: E402

SKIP = {"elapsed_s", "started_at", "software_version", "inputs", "timings_s", "timing_s"}


def _cases():
    for cfg in ("ideal", "all"):
        out = run_height_case(cfg, seed=5, minutes=4.0)
        names = ("tilt", "calibrate", "height", "navigate", "dov")
        yield from ((f"height-{cfg}/{k}", v) for k, v in out.items() if k in names)
    for cfg in ("ideal", "all"):
        out = run_gravity_case(cfg)
        yield from ((f"gravity-{cfg}/{k}", v) for k, v in out.items() if k.startswith("gravity"))
        out = run_damping_case(cfg)
        yield f"damping-{cfg}/damping", out["damping"]
    sim = simulate(catalog.gravity(n_lines=2, line_km=3.0, fix_schedule=[], with_ldv=False), seed=5)
    log = parse_files(bundle_files(sim))
    for name, params in (("navigate", {}), ("gravity", {"fir_length_s": 120.0}), ("dov", {"degree": 360})):
        yield f"noldv/{name}", _run(name, [log], params)
    rates = {"imu_rate_hz": 50.0, "ldv_rate_hz": 50.0}
    days = [survey.day(0, seed=1, **rates), survey.day(0, seed=2, date="2023-03-21", **rates)]
    logs = [parse_files(bundle_files(simulate(d))) for d in days]
    field = survey.survey_field()
    ties = []
    for lat, lon, h in survey.tie_points(road=0):
        g = normal_gravity(np.radians(lat), h) / MGAL + field.dg_mgal(np.radians(lat), np.radians(lon))
        ties.append(f"{lat:.9f},{lon:.9f},{h:.3f},{g:.4f}")
    params = {"fir_length_s": 200.0, "gnss_comparison": False, "base_ties": ";".join(ties)}
    yield "network/gravity", _run("gravity", logs, params)


def _run(name, logs, params):
    try:
        return run_pipeline(get(name), logs, params)
    except Exception as e:  # noqa: BLE001 - a crash is recorded and compared as a result
        return e


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _flat(x, path=""):
    """(path, value) for every leaf, numbers as float arrays."""
    if isinstance(x, dict):
        for k in sorted(x, key=str):
            if k in SKIP:
                continue
            yield from _flat(x[k], f"{path}.{k}")
    elif isinstance(x, (list, tuple)) and not (x and all(_number(v) for v in x)):
        for i, v in enumerate(x):
            yield from _flat(v, f"{path}[{i}]")
    elif isinstance(x, np.ndarray) and x.dtype.kind in "fiu":
        yield path, np.asarray(x, float)
    elif isinstance(x, (list, tuple)):
        yield path, np.asarray(x, float)
    elif isinstance(x, str):
        yield path, re.sub(r"/ldv-matrix-[^/]+/", "/ldv-matrix-TMP/", x)  # a temporary folder's name
    elif isinstance(x, (bool, type(None), np.ndarray)) or isinstance(x, np.bool_):
        yield path, x if not isinstance(x, np.ndarray) else x.tolist()
    elif isinstance(x, (int, float, np.integer, np.floating)):
        yield path, np.asarray([float(x)])
    else:
        yield path, repr(x)


def _record(result) -> dict:
    if isinstance(result, Exception):
        return {".error": f"{type(result).__name__}: {result}"}
    data = {"summary": result.summary, "tables": result.tables, "warnings": result.warnings}
    data["files"] = sorted(result.files)
    return dict(_flat(data))


def _close(a, b, rtol: float) -> bool:
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        if a.shape != b.shape:
            return False
        both_nan = np.isnan(a) & np.isnan(b)
        scale = np.maximum(np.abs(a), np.abs(b))
        ok = both_nan | (a == b) | (np.abs(a - b) <= rtol * scale)
        return bool(np.all(ok))
    return a == b


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("record", "compare"))
    ap.add_argument("dir", type=pathlib.Path)
    ap.add_argument("--rtol", type=float, default=1e-12)
    a = ap.parse_args()
    t0 = time.perf_counter()
    got = {}
    for name, result in _cases():
        got[name] = _record(result)
        r = got[name]
        print(f"{name}: {'error ' + r['.error'] if '.error' in r else len(r)} values", flush=True)
    if a.mode == "record":
        a.dir.mkdir(parents=True, exist_ok=True)
        (a.dir / "results.pkl").write_bytes(pickle.dumps(got))
        print(f"recorded {len(got)} results in {a.dir} ({time.perf_counter() - t0:.0f} s)")
        return 0
    before = pickle.loads((a.dir / "results.pkl").read_bytes())
    bad = 0
    for case in sorted(set(before) | set(got)):
        b, g = before.get(case), got.get(case)
        if b is None or g is None:
            print(f"{case}: only {'after' if b is None else 'before'}")
            bad += 1
            continue
        for key in sorted(set(b) | set(g)):
            if key not in b or key not in g:
                print(f"{case} {key}: only {'after' if key not in b else 'before'}")
                bad += 1
            elif not _close(b[key], g[key], a.rtol):
                x, y = b[key], g[key]
                if isinstance(x, np.ndarray) and isinstance(y, np.ndarray) and x.shape == y.shape:
                    d = np.nanmax(np.abs(x - y) / np.maximum(np.abs(x), 1e-300))
                    print(f"{case} {key}: max relative difference {d:.3g}")
                else:
                    print(f"{case} {key}: {str(x)[:80]} -> {str(y)[:80]}")
                bad += 1
    verdict = "identical" if not bad else f"{bad} differences"
    print(f"{verdict} within rtol {a.rtol:g} ({time.perf_counter() - t0:.0f} s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
