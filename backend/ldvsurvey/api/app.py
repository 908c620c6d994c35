"""The FastAPI application: REST under ``/api``, the dashboard's static pages at ``/``."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.middleware.gzip import GZipMiddleware
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles

from ldvsurvey import __version__
from ldvsurvey.api.auth import RateLimiter, bootstrap_users
from ldvsurvey.api.auth import router as auth_router
from ldvsurvey.api.compare import router as compare_router
from ldvsurvey.api.docs import mount_docs
from ldvsurvey.api.grids import router as grids_router
from ldvsurvey.api.imports import router as imports_router
from ldvsurvey.api.jobs import router as jobs_router
from ldvsurvey.api.limits import BodySizeLimit
from ldvsurvey.api.logs import router as logs_router
from ldvsurvey.api.models import Health
from ldvsurvey.api.people import router as people_router
from ldvsurvey.api.reports import router as reports_router
from ldvsurvey.api.security import SecurityHeaders
from ldvsurvey.api.storage import router as storage_router
from ldvsurvey.api.throttle import LoginThrottle
from ldvsurvey.api.ties import router as ties_router
from ldvsurvey.errors import InputError
from ldvsurvey.settings import Settings, get_settings
from ldvsurvey.store.db import ping, upgrade_head

FRONTEND_DIR = Path(__file__).resolve().parents[3] / "frontend"


def _say_how_to_log_in(url: str, settings: Settings) -> None:
    import logging

    from ldvsurvey.store.db import session_scope
    from ldvsurvey.store.users import count_admins

    with session_scope(url) as s:
        admins = count_admins(s)
    if not admins and not settings.demo_mode:
        logging.getLogger("ldvsurvey").warning(
            "no admin yet: create one with `ldv-survey user add NAME --admin`, or start with "
            "LDVSURVEY_ADMIN_USER and LDVSURVEY_ADMIN_PASSWORD set (see the README)"
        )


@asynccontextmanager
async def _lifespan(app: FastAPI) -> AsyncIterator[None]:
    """Start the app's job consumer (``app.state.consumer``) when the server starts, stop it when it
    stops; when jobs run in this process, compile the numerical core (or, when it is compiled, import
    the pipelines) in the background first."""
    app.state.consumer.start()
    if app.state.settings.run_consumer:
        import logging

        from ldvsurvey.pipelines.warmup import ready_for_jobs

        ready_for_jobs(log=logging.getLogger("ldvsurvey.warmup").info)
    yield
    app.state.consumer.stop()


def _add_plotly_bundle(app: FastAPI) -> None:
    """``GET /vendor/plotly.min.js``: the installed plotly package's bundle, gzip-compressed once per process."""
    import plotly

    plotly_js = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"

    gz_cache: dict = {}

    @app.get("/vendor/plotly.min.js", include_in_schema=False)
    def plotly_bundle(request: Request):
        import gzip

        from fastapi.responses import FileResponse, Response

        # the bundle changes only with the installed plotly package: let browsers keep it (and V8 its code cache)
        cache = {"Cache-Control": "public, max-age=86400", "Vary": "Accept-Encoding"}
        if "gzip" not in request.headers.get("accept-encoding", ""):
            return FileResponse(plotly_js, media_type="text/javascript", headers=cache)
        if "gz" not in gz_cache:  # compressed once per process, not on every request
            gz_cache["gz"] = gzip.compress(plotly_js.read_bytes(), compresslevel=6)
        return Response(gz_cache["gz"], media_type="text/javascript", headers={**cache, "Content-Encoding": "gzip"})


def _add_job_runner(app: FastAPI, settings: Settings, leftovers) -> None:
    """The app's job runner (``app.state.runner``) and its consumer (``app.state.consumer``), which also
    cleans what stopped uploads left every ``settings.clean_every_s`` into the ``leftovers`` report."""
    from ldvsurvey.jobs.runner import Consumer, JobRunner
    from ldvsurvey.store.leftovers import clean_leftovers

    url = app.state.database_url
    app.state.runner = JobRunner(url, settings)  # routes queue jobs through it (ldvsurvey.api.deps.RunnerDep)
    app.state.consumer = Consumer(  # started and stopped with the server (_lifespan)
        app.state.runner,
        workers=settings.workers,
        reap_every_s=settings.reap_every_s,
        consume=settings.run_consumer,
        housekeeping=lambda: clean_leftovers(settings, leftovers),
        housekeeping_every_s=settings.clean_every_s,
    )


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the app on the settings' database, migrated to the newest schema (``upgrade head``) first.

    Parameters
    ----------
    settings : Settings, optional
        The app's settings (default: :func:`ldvsurvey.settings.get_settings`, from the environment);
        routes read them through ``SettingsDep``.

    Returns
    -------
    FastAPI
        The app, holding its database URL, runner, job consumer and rate limiters in ``app.state``
        (the consumer starts and stops with the server).
    """
    settings = settings or get_settings()
    url = settings.resolved_database_url()
    upgrade_head(url)
    if not url.startswith("sqlite"):  # SQLite keeps its blob folder beside the file; a server uses the data dir
        from ldvsurvey.store.blobs import register_root

        register_root(url, Path(settings.data_dir) / "blobs")
    from ldvsurvey.store.leftovers import Report, clean_leftovers

    leftovers = Report()
    clean_leftovers(settings, leftovers)  # what a process killed mid-upload left behind
    app = FastAPI(
        title="ldv-survey",
        version=__version__,
        docs_url=None,
        redoc_url=None,
        description="Drive logs of SINS + LDV + GNSS: upload, validate, process, compare.",
        lifespan=_lifespan,
    )
    app.state.settings = settings
    app.state.database_url = url
    app.state.leftovers = leftovers  # what was cleaned (GET /api/admin/storage)
    app.state.rate_limiter = RateLimiter()
    app.state.login_throttle = LoginThrottle(url, settings)
    if settings.auth_enabled:
        bootstrap_users(url, settings)
        _say_how_to_log_in(url, settings)

    @app.exception_handler(InputError)
    async def _input_error(_request: Request, exc: InputError):
        return JSONResponse(status_code=exc.status_code, content={"detail": str(exc), "error": exc.to_dict()})

    @app.get("/api/health", tags=["meta"], summary="Liveness and database reachability")
    def health() -> Health:
        """The server's version and its database's dialect once a ``SELECT 1`` went through; 500 when
        the database cannot be reached."""
        return {"status": "ok", "version": __version__, "database": ping(url)}

    app.include_router(auth_router)
    app.include_router(people_router)
    app.include_router(logs_router)
    app.include_router(jobs_router)
    app.include_router(compare_router)
    mount_docs(app)
    app.include_router(imports_router)
    app.include_router(grids_router)
    app.include_router(storage_router)
    app.include_router(reports_router)
    app.include_router(ties_router)

    _add_plotly_bundle(app)
    _add_job_runner(app, settings, leftovers)

    if FRONTEND_DIR.is_dir():
        app.mount("/", StaticFiles(directory=FRONTEND_DIR, html=True), name="frontend")
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_upload_bytes)
    app.add_middleware(GZipMiddleware, minimum_size=1024, compresslevel=5)
    if settings.security_headers:
        # outermost: every answer carries them, refusals too
        app.add_middleware(SecurityHeaders, tile_origin=settings.basemap_origin())
    return app
