"""All pipelines by name, and the ``ldv-survey run`` entry point."""

from __future__ import annotations

from ldvsurvey.errors import ParameterError
from ldvsurvey.pipelines import calibrate, damping, dov, gravity, height, navigate, tilt
from ldvsurvey.pipelines.base import LogFacts, Pipeline, parse_set_args, run_pipeline, write_result

PIPELINES: dict[str, Pipeline] = {p.name: p for p in (calibrate.PIPELINE, tilt.PIPELINE, height.PIPELINE,
                                                     navigate.PIPELINE, gravity.PIPELINE,
                                                     dov.PIPELINE, damping.PIPELINE)}


def get(name: str) -> Pipeline:
    try:
        return PIPELINES[name]
    except KeyError:
        raise ParameterError(f"unknown pipeline '{name}' (known: {', '.join(sorted(PIPELINES))})",
                             field="PIPELINE") from None


def run_pipeline_cli(name: str, bundles: list[str], out: str, sets: list[str]) -> int:
    """``ldv-survey run``: load the bundles, run, write summary.json and the CSV tables."""
    import sys

    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.pipelines.base import Progress

    pipe = get(name)
    params = parse_set_args(sets)
    pipe.validate(params)  # unknown, malformed or out-of-range parameters fail before any work
    logs = [load_bundle(b) for b in bundles]
    pipe.check([LogFacts.of_log(log) for log in logs], params)  # and a pipeline that cannot apply
    if pipe.cli_setup is not None:
        pipe.cli_setup()

    def report(stage, frac):
        print(f"[{frac * 100:5.1f} %] {stage}", file=sys.stderr)

    result = run_pipeline(pipe, logs, params, Progress(report))
    for p in write_result(result, out):
        print(p)
    return 0
