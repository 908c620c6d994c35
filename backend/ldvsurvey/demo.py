"""The built-in demo: simulated bundles written to disk and loaded into the store."""

from __future__ import annotations

from pathlib import Path

from ldvsurvey.errors import ParameterError


def write_demo(
    directory: str | Path, scenario: str = "height", seed: int = 1, duration_s: float | None = None
) -> list[Path]:
    """Write a simulated bundle to ``directory`` (the four files), its truth to ``directory/truth``
    and, when the scenario has a gravity field with deflections, the ICGEM grids ``xi.gdf``,
    ``eta.gdf`` (arcsec) and ``dg.gdf`` (mGal) to ``directory/grids``."""
    import inspect

    from ldvsurvey.sim.catalog import REALISTIC, SCENARIOS, by_name

    if scenario not in SCENARIOS:
        raise ParameterError(
            f"unknown scenario '{scenario}' (known: {', '.join(sorted(SCENARIOS))})", field="--scenario"
        )
    kw = {}
    if duration_s:
        if "minutes" not in inspect.signature(SCENARIOS[scenario]).parameters:
            raise ParameterError(f"scenario '{scenario}' has a fixed length (no --duration-s)", field="--duration-s")
        kw["minutes"] = duration_s / 60.0
    if scenario in REALISTIC:
        kw["seed"] = seed
    try:
        sc = by_name(scenario, **kw)
    except ValueError as e:  # a length the scenario cannot be driven in
        raise ParameterError(str(e), field="--duration-s") from None
    return write_scenario(sc, directory, seed=seed)


def write_scenario(sc, directory: str | Path, seed: int | None = None) -> list[Path]:
    """Simulate a scenario and write bundle, truth and (if any) DOV grids under ``directory``.

    Returns the paths written: the bundle folder, ``truth/`` and, if written, ``grids/``.
    """
    from ldvsurvey.io.writers import write_bundle
    from ldvsurvey.sim.scenario import bundle_files, grid_files, simulate, truth_files

    sim = simulate(sc, seed=seed, with_nodov=sc.gravity_field is not None)
    out = Path(directory)
    write_bundle(bundle_files(sim), out)
    write_bundle(truth_files(sim), out / "truth")
    paths = [out, out / "truth"]
    grids = grid_files(sim)
    if grids:
        write_bundle(grids, out / "grids")
        paths.append(out / "grids")
    return paths


DEMO = (("height", "height"), ("gravity", "gravity"))  # (scenario, pipeline run on it)


def load_demo_survey(database_url: str, data_dir: Path, enqueue) -> list[int]:
    """Simulate the demo bundles once (cached under data_dir/demo), store them, and queue their
    pipelines (``enqueue(job_id)``, the app's ``JobRunner.enqueue``) unless a job for them exists
    already. Returns the log ids."""
    from sqlalchemy import select

    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.io.quality import quality_report
    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.logs import store_log
    from ldvsurvey.store.models import Job

    ids = []
    for scenario, pipeline in DEMO:
        folder = Path(data_dir) / "demo" / scenario
        if not (folder / "manifest.json").exists():
            print(f"simulating the demo {scenario} drive (first start only)…", flush=True)
            write_demo(folder, scenario=scenario)
        log = load_bundle(folder)
        with session_scope(database_url) as s:
            from ldvsurvey.store.users import get_or_create_project

            project = get_or_create_project(s, "Demo survey")
            row, _ = store_log(s, log, quality_report(log), project.id)
            log_id = row.id
            job = s.scalar(select(Job).where(Job.pipeline == pipeline))
            if job is None or log_id not in job.log_ids:
                job = Job(
                    pipeline=pipeline, log_ids=[log_id], parameters={}, status="queued", stage="queued", progress=0.0
                )
                s.add(job)
                s.flush()
                new_job = job.id
            else:
                new_job = None
        if new_job is not None:
            enqueue(new_job)
        ids.append(log_id)
    return ids
