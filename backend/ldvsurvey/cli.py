"""The ``ldv-survey`` command line (see ``spec/results.md``).

Exit codes: 0 success, 2 invalid input or parameters (message names file, line, field),
1 internal error.
"""

from __future__ import annotations

import argparse
import atexit
import gc
import json
import os
import sys
import traceback

from ldvsurvey import __version__
from ldvsurvey.errors import InputError


def _cmd_validate(args) -> int:
    from ldvsurvey.io.drivelog import load_bundle
    from ldvsurvey.io.quality import quality_report

    log = load_bundle(args.bundle)
    report = quality_report(log)
    if report["gnss"] is not None:  # the per-run timeline is for the dashboard, not the terminal
        report["gnss"].pop("fix_timeline", None)
    m = log.manifest
    print(
        f"{args.bundle}: valid {m.format} bundle '{m.name}' ({m.platform}, "
        f"{'no LDV' if m.ldv is None else 'LDV ' + m.ldv.kind}, {'GNSS' if log.gnss is not None else 'no GNSS'}, "
        f"IMU {'rotating' if m.imu.rotating else 'fixed'}), {report['duration_s']:.1f} s"
    )
    if args.json:
        print(json.dumps(report, indent=2))
    for w in log.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return 0


def _cmd_serve(args) -> int:
    import uvicorn

    from ldvsurvey.api.app import create_app
    from ldvsurvey.settings import get_settings

    settings = get_settings()
    if settings.run_consumer:  # jobs run in this process: so does the compile
        _show_compile_progress()
    if args.demo:  # visitors act as the clearly marked demo account
        settings = settings.model_copy(update={"demo_mode": True})
    app = create_app(settings)
    if args.demo:
        from ldvsurvey.demo import load_demo_survey

        load_demo_survey(app.state.database_url, settings.data_dir, app.state.runner.enqueue)
        print(f"dashboard with the demo survey: http://{args.host}:{args.port}/", flush=True)
    # X-Forwarded-For is read by the app itself, only from LDVSURVEY_TRUSTED_PROXIES
    # (ldvsurvey.api.throttle.client_address): uvicorn must not believe it from 127.0.0.1 first
    uvicorn.run(app, host=args.host, port=args.port, log_level="info", proxy_headers=False)
    return 0


def _show_compile_progress() -> None:
    """Print the background compile's progress (ldvsurvey.warmup) on the server's terminal: on a
    first start the server listens while the numerical core compiles, and says how far it is."""
    import logging

    from ldvsurvey.pipelines.warmup import is_warm

    lg = logging.getLogger("ldvsurvey.warmup")
    if lg.handlers:
        return
    h = logging.StreamHandler(sys.stdout)
    h.setFormatter(logging.Formatter("%(asctime)s compiling the numerical core: %(message)s", "%H:%M:%S"))
    lg.addHandler(h)
    lg.setLevel(logging.INFO)
    if not is_warm():
        print(
            "the numerical core compiles in the background (about 2 minutes on 2 cores, once per installation); "
            "jobs started meanwhile wait for it and say so on their page",
            flush=True,
        )


def _cmd_demo(args) -> int:
    from ldvsurvey.demo import write_demo

    paths = write_demo(args.dir, scenario=args.scenario, seed=args.seed, duration_s=args.duration_s)
    for p in paths:
        print(p)
    return 0


def _own_process_start(load) -> None:
    """What a batch command's own process (``run``, ``import``) does before its work: the modules it
    needs, given by ``load()``, are imported with the garbage collector off (they make hundreds of
    thousands of objects that live as long as the process; no collection walks them while they are
    made, and none after: ``gc.freeze``), and pydantic does not scan every installed package's
    entry points for plugins when the manifest's models are built (0.02 s; ldv-survey uses none; a
    ``PYDANTIC_DISABLE_PLUGINS`` already set, even empty, is kept)."""
    os.environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")
    gc.disable()
    try:
        load()
    finally:
        gc.freeze()
        gc.enable()


def _cmd_run(args) -> int:
    from ldvsurvey.pipelines.registry import get, run_pipeline_cli

    if getattr(args, "own_process", False):
        from ldvsurvey.compilecache import preload_blas

        preload_blas()  # numba's BLAS check would import all of scipy.linalg (0.2 s)
        _own_process_start(lambda: get(args.pipeline))  # an unknown name fails here as it would below
    rc = run_pipeline_cli(args.pipeline, args.bundles, args.out, args.set or [], open_grid_cache=_db_grid_cache)
    if rc == 0 and args.format != "csv":
        for p in export_geo_files(args.out, args.format, args.bundles[0]):
            print(p)
    return rc


def _db_grid_cache():
    """The application database's grid cache (migrated first): synthesized grids kept between runs."""
    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.db import upgrade_head
    from ldvsurvey.store.gridcache import DbGridCache

    url = get_settings().resolved_database_url()
    upgrade_head(url)
    return DbGridCache(url)


def export_geo_files(out_dir, fmt: str, bundle) -> list:
    """Beside the CSV tables in ``out_dir``, the same tables as GeoJSON or KML (with provenance)."""
    from pathlib import Path

    from ldvsurvey.io.writers import geo_export, gnss_track

    out = Path(out_dir)
    summary = json.loads((out / "summary.json").read_text())
    track, paths = None, []
    for csv_path in sorted(out.glob("*.csv")):
        data = csv_path.read_bytes()
        header = data.split(b"\n", 1)[0].decode()
        if "lat_deg" not in header.split(","):
            if "t_s" not in header.split(","):
                continue  # no time, no position (coincidence.csv): nothing to draw
            if track is None:
                from ldvsurvey.io.drivelog import load_bundle

                track = gnss_track(load_bundle(bundle)) or {}
            if not track:
                continue
        name, content = geo_export(fmt, csv_path.stem, data, summary, track or None)
        (out / name).write_bytes(content)
        paths.append(out / name)
    return paths


def _parse_source(role: str, spec: str):
    from ldvsurvey.errors import BundleError
    from ldvsurvey.io.importers import REGISTRY, Source

    fmt, sep, path = spec.partition(":")
    if not sep or not path:
        raise BundleError(f"expected FORMAT:FILE (formats: {', '.join(REGISTRY)}), got '{spec}'", field=f"--{role}")
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise BundleError("no such file", file=path, field=f"--{role}")
    return Source(role=role, format=fmt.lower(), name=p.name, data=p.read_bytes())


def _cmd_import(args) -> int:
    import os
    import tempfile
    from pathlib import Path

    if getattr(args, "own_process", False):
        import importlib

        modules = ("ldvsurvey.io.importers.build", "ldvsurvey.io.drivelog", "ldvsurvey.io.writers")
        _own_process_start(lambda: [importlib.import_module(m) for m in modules])
    from ldvsurvey.errors import BundleError
    from ldvsurvey.io.importers import build_bundle, parse_partial_manifest
    from ldvsurvey.io.writers import write_bundle

    sources = [
        _parse_source(role, spec) for role, spec in (("imu", args.imu), ("gnss", args.gnss), ("ldv", args.ldv)) if spec
    ]
    mpath = Path(args.manifest)
    if not mpath.is_file():
        raise BundleError("no such file", file=args.manifest, field="--manifest")
    partial = parse_partial_manifest(mpath.read_bytes(), file=mpath.name)
    if args.axes:  # the IMU's sensor axes, for any format (overrides import.imu.axes)
        imp = partial.setdefault("import", {})
        if not isinstance(imp, dict) or not isinstance(imp.setdefault("imu", {}), dict):
            raise BundleError("must be an object", file=mpath.name, field="import.imu")
        imp["imu"]["axes"] = args.axes
    result = build_bundle(sources, partial)
    out = Path(args.out)
    if out.suffix.lower() != ".zip":
        raise BundleError("the output must be a .zip path", file=args.out, field="--out")
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".zip", dir=out.parent)  # nothing appears at --out unless all went well
    os.close(fd)
    beside = {out.with_name(f"{out.stem}.{name}"): content for name, content in result.beside.items()}
    tmps = {}
    try:
        write_bundle(result.files, tmp)
        for path, content in beside.items():  # e.g. the receiver's INS solution: BUNDLE.reference.csv
            fd, tmps[path] = tempfile.mkstemp(suffix=path.suffix, dir=out.parent)
            with os.fdopen(fd, "wb") as f:
                f.write(content)
        os.replace(tmp, out)
        for path, t in tmps.items():
            os.replace(t, path)
    finally:
        for t in [tmp, *tmps.values()]:
            if os.path.exists(t):
                os.unlink(t)
    s = result.summary
    print(
        f"{out}: {', '.join(f['role'] + '=' + f['format'] for f in s['files'])}; {s['date']}, "
        f"t {s['time_span_s'][0]:.3f}-{s['time_span_s'][1]:.3f} s; IMU {s['rates_hz']['imu']} Hz "
        f"(axes {s['imu_axes']}, static tilt {s['static_tilt_deg']:.2f} deg), "
        + ("no LDV" if s["rates_hz"]["ldv"] is None else f"LDV {s['rates_hz']['ldv']} Hz")
    )
    ck = s.get("checks") or {}
    g, r, o = ck.get("static_gravity") or {}, ck.get("imu_rate") or {}, ck.get("overlap")
    if "normal_mps2" in g:
        print(
            f"check: at rest |f| {g['measured_mps2']:.4f} m/s² vs normal gravity {g['normal_mps2']:.4f} m/s² "
            f"({g['error_rel'] * 100:+.2f} %), |ω| {g['omega_dph']:.3f} °/h vs Earth rate {g['earth_rate_dph']:.3f} °/h"
        )
    if r:
        print(
            f"check: IMU rate {r['measured_hz']} Hz measured"
            + (f", {r['declared_hz']} Hz declared" if r.get("declared_hz") else "")
        )
    if o:
        print(f"check: GNSS covers {o['share'] * 100:.1f} % of the IMU span ({o['overlap_s']} s)")
    tb = (ck.get("imu_source") or {}).get("time_base")
    if tb:
        print(
            f"check: {tb['message']} time base from {tb['anchors']} {tb['source']} epochs: tag rate "
            f"{tb['tag_rate_hz']:.1f} ticks/s ± {tb['tag_rate_3sigma_rel'] * 100:.2f} % (3σ), "
            f"offset ± {tb['offset_uncertainty_ms']} ms"
        )
    if "reference" in s:
        for path in beside:
            print(f"{path}: reference trajectory, {s['reference']['epochs']} epochs of {s['reference']['source']}")
    for w in result.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return 0


def _cmd_warmup(args) -> int:
    from ldvsurvey.pipelines.warmup import warmup

    report = warmup(
        args.pipeline or None, variants=not args.no_variants, log=lambda line: print(line, file=sys.stderr, flush=True)
    )
    if args.json:
        print(json.dumps(report.as_dict(), indent=2))
    else:
        print(
            f"numba cache {report.cache_dir}: {report.compiled} signature(s) compiled, "
            f"{report.cache_hits} loaded from the cache, {report.elapsed_s:.1f} s"
        )
    for name in report.not_cached:
        print(f"warning: {name} is compiled in every process (no cache=True)", file=sys.stderr)
    missed = [r.pipeline for r in report.runs if not r.ok and not r.parameters]
    for name in missed:
        print(f"warning: pipeline '{name}' was not warmed: no tiny simulated log suits it", file=sys.stderr)
    return 1 if missed else 0


def _cmd_migrate(args) -> int:
    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.db import upgrade_head

    url = get_settings().resolved_database_url()
    upgrade_head(url)
    print("database at head")
    return 0


def _cmd_clean(args) -> int:
    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.leftovers import clean_leftovers, folders_of, scan

    settings = get_settings()
    gone = clean_leftovers(settings)
    print(f"{gone.message()} left by stopped processes (killed mid-upload)")
    for p in gone.paths:
        print(f"  {p}")
    _, busy = scan(*folders_of(settings), remove=False)
    if busy.staging_folders or busy.part_blobs:
        print(f"kept: {busy.message('in progress:')} held by running processes")
    return 0


def _cmd_blobs(args) -> int:
    from pathlib import Path

    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.blobs import migrate_to_database
    from ldvsurvey.store.db import upgrade_head

    settings = get_settings()
    url = settings.resolved_database_url()
    if url.startswith("sqlite"):
        print("SQLite keeps its blobs in the folder beside the database file: nothing to migrate")
        return 0
    upgrade_head(url)
    folder = Path(args.folder) if args.folder else Path(settings.data_dir) / "blobs"
    n, nbytes = migrate_to_database(url, folder)
    print(f"moved {n} blobs ({nbytes / 1e6:.1f} MB) from {folder} into the database")
    return 0


def _cmd_backup(args) -> int:
    from pathlib import Path

    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.backup import backup
    from ldvsurvey.store.db import upgrade_head

    url = get_settings().resolved_database_url()
    upgrade_head(url)
    backup(url, Path(args.dir))
    return 0


def _cmd_restore(args) -> int:
    from pathlib import Path

    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.backup import restore

    restore(get_settings().resolved_database_url(), Path(args.dir), force=args.force)
    return 0


def _db():
    from ldvsurvey.settings import get_settings
    from ldvsurvey.store.db import session_scope, upgrade_head

    url = get_settings().resolved_database_url()
    upgrade_head(url)
    return session_scope(url)


def _password(args) -> str:
    import getpass
    import os

    if args.password_env:
        pw = os.environ.get(args.password_env)
        if not pw:
            raise InputError(f"environment variable {args.password_env} is empty or unset", field="password")
        return pw
    pw = getpass.getpass("password: ")
    if pw != getpass.getpass("again: "):
        raise InputError("the two passwords differ", field="password")
    return pw


def _cmd_user(args) -> int:
    from ldvsurvey.store import users as ustore

    with _db() as s:
        if args.action == "add":
            pw = _password(args)
            ustore.check_password(pw)
            u = ustore.create_user(s, args.username, pw, is_admin=args.admin, own_project=not args.project)
            for p in args.project or []:
                ustore.add_member(s, u.id, ustore.find_project(s, p).id)
            print(f"user '{u.username}' created{' (admin)' if args.admin else ''}")
        elif args.action == "list":
            for u in ustore.list_users(s):
                flags = [
                    f for f, on in (("admin", u["is_admin"]), ("demo", u["is_demo"]), ("disabled", u["disabled"])) if on
                ]
                print(
                    f"{u['id']}\t{u['username']}\t{','.join(flags) or '-'}\t"
                    f"{'; '.join(p['name'] for p in u['projects']) or '-'}"
                )
        elif args.action in ("disable", "enable"):
            ustore.set_disabled(s, ustore.find_user(s, args.username), args.action == "disable")
            print(f"user '{args.username}' {args.action}d")
        elif args.action == "delete":
            user = ustore.find_user(s, args.username)
            if not args.yes:
                raise InputError(f"deleting '{user.username}': {ustore.USER_DELETE_EFFECT}; add --yes", field="--yes")
            out = ustore.delete_user(s, user)
            print(f"user '{out['deleted']}' deleted: {out['effect']}")
        elif args.action == "password":
            user = ustore.find_user(s, args.username)
            ustore.set_password(s, user, _password(args))
            print(f"password of '{args.username}' set")
    return 0


def _cmd_project(args) -> int:
    from ldvsurvey.store import users as ustore

    with _db() as s:
        if args.action == "add":
            p = ustore.create_project(s, args.name)
            print(f"project {p.id} '{p.name}' created")
        elif args.action == "list":
            for p in ustore.list_projects(s):
                print(f"{p['id']}\t{p['name']}\t{', '.join(p['members']) or '-'}")
        elif args.action == "delete":
            p = ustore.find_project(s, args.name)
            n = next(x["n_logs"] for x in ustore.list_projects(s, [p.id]))
            if not args.yes:
                raise InputError(
                    f"deleting '{p.name}' ({n} logs): {ustore.PROJECT_DELETE_EFFECT}; add --yes", field="--yes"
                )
            out = ustore.delete_project(s, p)
            print(f"project '{out['deleted']}' deleted with {out['logs_deleted']} logs and {out['jobs_deleted']} jobs")
        elif args.action == "member":
            p, u = ustore.find_project(s, args.name), ustore.find_user(s, args.username)
            if args.remove:
                ustore.remove_member(s, u.id, p.id)
                print(f"'{u.username}' removed from '{p.name}'")
            else:
                ustore.add_member(s, u.id, p.id)
                print(f"'{u.username}' is a member of '{p.name}'")
    return 0


_FORMATS_HEADING = "Formats (FORMAT in FORMAT:FILE), the roles they read and what:\n"


class _ImportHelpFormatter(argparse.RawDescriptionHelpFormatter):
    """``import --help``: the formats' lines are added only when the help is shown (listing them
    imports every importer, which every other command, ``run`` included, would pay for at start)."""

    def add_text(self, text):
        if text is _FORMATS_HEADING:
            from ldvsurvey.io.importers import formats_help

            text = text + formats_help()
        super().add_text(text)


def _cmd_ties(args) -> int:
    from ldvsurvey.pipelines.ties import base_ties_text, check_tie
    from ldvsurvey.store import ties as tstore
    from ldvsurvey.store import users as ustore

    with _db() as s:
        p = ustore.find_project(s, args.project)
        if args.action == "list":
            rows = tstore.list_ties(s, p.id)
            for k, t in enumerate(rows):
                print(
                    f"T{k + 1}\t{t.id}\t{t.name}\t{t.lat_deg:.9f}\t{t.lon_deg:.9f}\t{t.h_m:.3f} m\t"
                    f"{t.g_mgal:.4f} ± {t.sigma_mgal:g} mGal\t{t.note}"
                )
            text = base_ties_text(rows)
            print(f"base_ties={text}" if text else f"project '{p.name}' has no base station")
        elif args.action == "add":
            values = check_tie(args.name, args.lat_deg, args.lon_deg, args.h_m, args.g_mgal, args.sigma_mgal, args.note)
            t = tstore.add_tie(s, p.id, values)
            print(f"base station {t.id} '{t.name}' added to '{p.name}'")
        elif args.action == "delete":
            rows = [t for t in tstore.list_ties(s, p.id) if args.tie in (t.name, str(t.id))]
            if not rows:
                raise InputError(f"project '{p.name}' has no base station {args.tie!r}", field="tie")
            tstore.delete_tie(s, rows[0])
            print(f"base station '{rows[0].name}' deleted from '{p.name}'")
    return 0


def _add_bundle_commands(sub) -> None:
    """The sub-commands on bundles: ``validate``, ``run``, ``demo`` and ``import``."""
    v = sub.add_parser("validate", help="check a bundle (.zip or folder); exit 0 if valid, else 2")
    v.add_argument("bundle")
    v.add_argument("--json", action="store_true", help="print the quality report as JSON")
    v.set_defaults(func=_cmd_validate)

    r = sub.add_parser("run", help="run a pipeline on one or more bundles")
    r.add_argument("pipeline")
    r.add_argument("bundles", nargs="+", metavar="BUNDLE")
    r.add_argument("--out", required=True, help="output folder for summary.json and the CSV tables")
    r.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a pipeline parameter")
    r.add_argument(
        "--format",
        choices=("csv", "geojson", "kml"),
        default="csv",
        help="also write the tables with positions as GeoJSON or KML (the CSV tables are always written)",
    )
    r.set_defaults(func=_cmd_run)

    d = sub.add_parser("demo", help="write a simulated bundle (the product's own simulator)")
    d.add_argument("dir")
    d.add_argument("--scenario", default="height")
    d.add_argument("--seed", type=int, default=1)
    d.add_argument("--duration-s", type=float, default=None, help="override the scenario's length")
    d.set_defaults(func=_cmd_demo)

    from ldvsurvey.io.importers import REGISTRY

    im = sub.add_parser(
        "import",
        help=f"turn field recordings ({', '.join(REGISTRY)}) into a validated bundle .zip",
        description=_FORMATS_HEADING,
        formatter_class=_ImportHelpFormatter,
    )
    im.add_argument("--imu", required=True, metavar="FORMAT:FILE")
    im.add_argument("--gnss", metavar="FORMAT:FILE")
    im.add_argument("--ldv", metavar="FORMAT:FILE", help="optional: an IMU with GNSS alone makes a bundle")
    im.add_argument(
        "--manifest",
        required=True,
        metavar="PARTIAL.json",
        help="what no recording holds: LDV kind and mounting, lever arms, platform, import options",
    )
    im.add_argument("--out", required=True, metavar="BUNDLE.zip")
    im.add_argument(
        "--axes",
        metavar="CODE",
        help="where the IMU's sensor x, y, z point (e.g. FRD, FLU, RFU), for any format; overrides import.imu.axes",
    )
    im.set_defaults(func=_cmd_import)


def _add_install_commands(sub) -> None:
    """The sub-commands that prepare an installation: ``warmup``, ``migrate`` and ``clean``."""
    w = sub.add_parser(
        "warmup",
        help="compile the numerical core into the on-disk cache by running every "
        "pipeline once on a tiny simulated log (scripts/setup.sh does this)",
    )
    w.add_argument("--pipeline", action="append", metavar="NAME", help="only this pipeline (repeatable)")
    w.add_argument("--no-variants", action="store_true", help="skip the non-default choice parameters")
    w.add_argument("--json", action="store_true", help="print the runs and the compile/cache counts as JSON")
    w.set_defaults(func=_cmd_warmup)

    mg = sub.add_parser("migrate", help="bring the database (LDVSURVEY_DATABASE_URL) to the newest schema")
    mg.set_defaults(func=_cmd_migrate)

    cl = sub.add_parser(
        "clean",
        help="remove the staging folders and .part blobs left by processes killed mid-upload "
        "(the server also does this at start and every LDVSURVEY_CLEAN_EVERY_S)",
    )
    cl.set_defaults(func=_cmd_clean)


def _add_storage_commands(sub) -> None:
    """The sub-commands on stored data: ``blobs migrate``, ``backup`` and ``restore``."""
    bl = sub.add_parser("blobs", help="where the large files of stored logs live")
    ba = bl.add_subparsers(dest="action", required=True)
    x = ba.add_parser(
        "migrate",
        help="PostgreSQL: move the blobs of an older blob folder into the database (safe to repeat, "
        "also while the server runs); SQLite keeps its folder",
    )
    x.add_argument("--folder", help="the old blob folder (default: LDVSURVEY_DATA_DIR/blobs)")
    bl.set_defaults(func=_cmd_blobs)

    x = sub.add_parser(
        "backup",
        help="copy the database and the stored logs' files into a new folder DIR, consistently while the "
        "server runs (SQLite: online backup; PostgreSQL: pg_dump), with the SHA-256 of every file",
    )
    x.add_argument("dir")
    x.set_defaults(func=_cmd_backup)
    x = sub.add_parser(
        "restore",
        help="check every file of a backup by SHA-256, then restore it (stop the server first)",
    )
    x.add_argument("dir")
    x.add_argument("--force", action="store_true", help="replace a database that already holds data")
    x.set_defaults(func=_cmd_restore)


def _add_user_commands(sub) -> None:
    """The ``user`` sub-command: ``add``, ``list``, ``disable``, ``enable``, ``delete`` and ``password``."""
    u = sub.add_parser("user", help="manage users (in LDVSURVEY_DATABASE_URL / LDVSURVEY_DATA_DIR)")
    ua = u.add_subparsers(dest="action", required=True)
    x = ua.add_parser("add", help="create a user (asks for the password unless --password-env)")
    x.add_argument("username")
    x.add_argument("--admin", action="store_true", help="may manage users and projects and sees every project")
    x.add_argument(
        "--project",
        action="append",
        help="make them a member (name or id; repeatable); without it they get a project of their own",
    )
    x.add_argument("--password-env", metavar="VAR", help="read the password from this environment variable")
    ua.add_parser("list", help="users, flags and projects")
    for act in ("disable", "enable"):
        x = ua.add_parser(act, help=f"{act} a user (a disabled user can not log in; tokens stop working)")
        x.add_argument("username")
    x = ua.add_parser(
        "delete", help="delete a user: sessions, tokens, memberships go; their logs and jobs stay in their projects"
    )
    x.add_argument("username")
    x.add_argument("--yes", action="store_true", help="do it (without: say what would happen, exit 2)")
    x = ua.add_parser("password", help="set a user's password (ends their sessions)")
    x.add_argument("username")
    x.add_argument("--password-env", metavar="VAR")
    u.set_defaults(func=_cmd_user)


def _add_project_commands(sub) -> None:
    """The ``project`` sub-command: ``add``, ``list``, ``delete`` and ``member``."""
    pr = sub.add_parser("project", help="manage projects and their members")
    pa = pr.add_subparsers(dest="action", required=True)
    x = pa.add_parser("add", help="create a project")
    x.add_argument("name")
    pa.add_parser("list", help="projects and their members")
    x = pa.add_parser("delete", help="delete a project with its logs, their files and every job computed from them")
    x.add_argument("name", help="project name or id")
    x.add_argument("--yes", action="store_true", help="do it (without: say what would happen, exit 2)")
    x = pa.add_parser("member", help="add (or --remove) a user to a project")
    x.add_argument("name", help="project name or id")
    x.add_argument("username")
    x.add_argument("--remove", action="store_true")
    pr.set_defaults(func=_cmd_project)

    ti = sub.add_parser("ties", help="a project's base stations (absolute gravity ties for base_ties)")
    ta = ti.add_subparsers(dest="action", required=True)
    x = ta.add_parser("list", help="the stations (Tn as a job numbers them) and their base_ties text")
    x.add_argument("project", help="project name or id")
    x = ta.add_parser("add", help="add a station (checked as base_ties checks it)")
    x.add_argument("project", help="project name or id")
    x.add_argument("name")
    for k, h in (("lat_deg", "deg"), ("lon_deg", "deg"), ("h_m", "ellipsoidal, m"), ("g_mgal", "absolute, mGal")):
        x.add_argument(k, type=float, help=h)
    x.add_argument("sigma_mgal", type=float, help="1-σ of g, mGal")
    x.add_argument("--note", default="", help="where the value comes from")
    x = ta.add_parser("delete", help="remove a station")
    x.add_argument("project", help="project name or id")
    x.add_argument("tie", help="station name or id")
    ti.set_defaults(func=_cmd_ties)


def _add_serve_command(sub) -> None:
    """The ``serve`` sub-command (the dashboard)."""
    s = sub.add_parser("serve", help="run the dashboard")
    s.add_argument("--host", default="127.0.0.1")
    s.add_argument("--port", type=int, default=8000)
    s.add_argument("--demo", action="store_true", help="load (and process) the built-in demo survey first")
    s.set_defaults(func=_cmd_serve)


def build_parser() -> argparse.ArgumentParser:
    """The ``ldv-survey`` argument parser: one sub-command per task, each with its handler as ``func``.

    Returns
    -------
    argparse.ArgumentParser
        The parser; ``parse_args`` gives a namespace whose ``func(args)`` runs the sub-command and
        returns its exit code.
    """
    p = argparse.ArgumentParser(prog="ldv-survey", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"ldv-survey {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    _add_bundle_commands(sub)
    _add_install_commands(sub)
    _add_storage_commands(sub)
    _add_user_commands(sub)
    _add_project_commands(sub)
    _add_serve_command(sub)
    return p


#: the exit code main() returned (or argparse exited with) in a process of its own, for :func:`_end_process`
_exit_code: int | None = None


def _end_process() -> None:
    """End a process that is this command's own: flush stdout and stderr, then ``os._exit`` with main's code,
    skipping the interpreter's teardown. Registered before the command runs, so it is the last exit handler:
    the handlers registered after it (logging, weakref finalizers, worker pools) have run.

    Why: a command's work is done and written when main returns; the teardown after it only frees memory, and
    in two libraries it goes wrong. (1) EDIE's nanobind extension checks at its teardown that every instance,
    type and function it made was freed, and prints a page of ``nanobind: leaked ...`` lines when not: main
    freezes its objects at the end (``gc.freeze``, to spare the last collection), the interpreter's final
    collections skip the frozen generation, so EDIE's module globals (in reference cycles, as every type is)
    stay alive and nanobind reports them. (2) pyarrow's threaded CSV reader finishes on an Arrow pool thread
    after ``read_csv`` has returned: that thread drops the reader's last reference to the Python file object
    it read, which takes the GIL. If the interpreter is finalising by then (a short command, a loaded
    machine), CPython ends the thread with ``pthread_exit`` inside ``take_gil``; the unwinding meets Arrow's
    noexcept destructors and ``std::terminate`` aborts the process (SIGABRT, "terminate called without an
    active exception") after its output was printed. Exit handlers run before the interpreter is marked as
    finalising, so ``os._exit`` here leaves such a thread waiting for the GIL, harmlessly, and runs neither.

    The code is main's (1 when an exception escaped the code that called main, as Python's own exit would
    say; a later ``sys.exit(n)`` of that code is not seen). A stdout that cannot be flushed (a closed pipe)
    turns a 0 into 1: the output was lost.
    """
    code = 1 if _exit_code is None else int(_exit_code)
    if getattr(sys, "last_value", None) is not None:  # an uncaught exception after main (printed by Python)
        code = 1
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing more can be written
            code = code or 1
    os._exit(code)


def main(argv: list[str] | None = None) -> int:
    """Run the ``ldv-survey`` command line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 success, 2 invalid input or parameters (the message names file, line,
        field), 130 interrupted, 1 internal error (the trace is printed). In a process of its own
        (no ``argv``) the process ends with it at exit, without the interpreter's teardown
        (:func:`_end_process`).
    """
    global _exit_code
    if argv is None:  # the process is this command's: its end is deterministic (see _end_process)
        atexit.register(_end_process)
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a usage error (2)
        _exit_code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        raise
    # without argv the process is this command's (the console script, python -m), not a caller's
    args.own_process = argv is None
    rc = 1
    try:
        rc = args.func(args)
        return rc
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        rc = 2
        return rc
    except KeyboardInterrupt:
        rc = 130
        return rc
    except SystemExit as exc:  # a command that exits (with its code)
        rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        raise
    except Exception:  # an internal error: say so, with the trace for a bug report
        traceback.print_exc()
        print("internal error (exit 1): please report it with the trace above", file=sys.stderr)
        return rc
    finally:
        if argv is None:
            _exit_code = rc
        if getattr(args, "own_process", False):
            # the process ends now: its last collection would walk every object once more to free
            # nothing the exit does not free (0.15–0.25 s of CPU)
            gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
