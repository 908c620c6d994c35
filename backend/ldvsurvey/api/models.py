"""Response models of the JSON routes: what ``/docs`` (OpenAPI) shows as each answer's schema.

Every model allows extra keys (``extra="allow"``) so that a key added to an answer is passed on
rather than refused; the declared fields are the documented contract. Free-form parts (a log's
manifest and quality report, a job's summary, Plotly figure traces) are ``dict[str, Any]``:
their content is documented in ``docs/results.md`` and ``docs/bundle-format.md``.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

JSON = dict[str, Any]


class Out(BaseModel):
    model_config = ConfigDict(extra="allow", populate_by_name=True)


class Ok(Out):
    ok: bool


class Health(Out):
    status: str
    version: str
    database: str = Field(description="SQLAlchemy dialect of the database (sqlite, postgresql)")


# --- people -------------------------------------------------------------------------------------


class LoginOut(Out):
    user: str
    csrf: str = Field(description="send it as X-CSRF-Token on every page write of this session")


class ProjectOut(Out):
    id: int
    name: str
    members: list[str] = Field(description="user names")
    n_logs: int = Field(0, description="logs stored in the project")


class UserDeleted(Out):
    deleted: str = Field(description="the user name")
    tokens_deleted: int
    memberships_deleted: int
    effect: str = Field(description="what happened to their data")


class ProjectDeleted(Out):
    deleted: str = Field(description="the project name")
    logs_deleted: int
    jobs_deleted: int
    effect: str = Field(description="what happened to its data")


class Me(Out):
    user: str | None
    auth: bool = Field(description="false: authentication is disabled (local single-user use)")
    csrf: str | None
    demo: bool
    admin: bool
    projects: list[int] | None = Field(description="ids of the projects you may see; null: all")
    project_list: list[ProjectOut]


class TokenOut(Out):
    id: int
    name: str
    created_at: str | None
    expires_at: str | None
    last_used_at: str | None
    expired: bool


class NewToken(TokenOut):
    token: str = Field(description="the secret, shown only in this answer")


class ProjectRef(Out):
    id: int
    name: str


class UserOut(Out):
    id: int
    username: str
    is_admin: bool
    is_demo: bool
    disabled: bool
    created_at: str
    projects: list[ProjectRef]


# --- base stations of a project --------------------------------------------------------------------


class TieOut(Out):
    id: int
    project_id: int
    name: str
    lat_deg: float = Field(description="geodetic latitude (deg)")
    lon_deg: float = Field(description="geodetic longitude (deg, east positive, -180 to 180)")
    h_m: float = Field(description="ellipsoidal height (m, WGS-84)")
    g_mgal: float = Field(description="absolute gravity (mGal)")
    sigma_mgal: float = Field(description="1-σ of g_mgal (mGal)")
    note: str = Field("", description="where the value comes from")
    created_at: str | None = None


class ProjectTies(Out):
    project_id: int
    ties: list[TieOut] = Field(description="in the order entered: the n-th is a gravity job's tie Tn")
    base_ties: str | None = Field(
        description="the gravity pipeline's base_ties parameter of these stations (LAT,LON,H_M,G_MGAL;...), "
        "none without a station"
    )


# --- logs ---------------------------------------------------------------------------------------


class Badges(Out):
    imu_gaps: int | None = None
    ldv_below_min_quality_share: float | None = None
    gnss_rtk_fixed_share: float | None = None
    warnings: int = 0


class LogSummary(Out):
    id: int
    name: str
    sha256: str = Field(description="SHA-256 of the bundle")
    project_id: int | None
    platform: str = Field(description="vehicle or vessel")
    ldv_kind: str = Field(description="1d, 2d, water, or none for a log without an LDV")
    imu_rotating: bool
    survey_date: str
    t_start_s: float = Field(description="first IMU epoch, s of day")
    t_end_s: float = Field(description="last IMU epoch, s of day")
    duration_s: float
    has_gnss: bool
    size_bytes: int
    created_at: str
    badges: Badges


class Uploaded(LogSummary):
    duplicate: bool = Field(description="the same bundle was already stored in the project")
    quality: JSON | None


class Imported(Uploaded):
    import_: JSON = Field(alias="import", description="the converted files and the converters' warnings")


class FileInfo(Out):
    name: str
    sha256: str
    size_bytes: int


class LogDetail(LogSummary):
    manifest: JSON
    quality: JSON | None
    files: list[FileInfo]


class ImportPreview(Out):
    files: Any
    time_span_s: Any
    rates_hz: Any
    gnss_track: Any
    date: Any
    imu_axes: Any
    static_tilt_deg: Any
    checks: Any = None  #: the import's cross-checks (dates, overlap, IMU rate, gravity/Earth rate at rest, time base)
    warnings: list[str]


# --- grids --------------------------------------------------------------------------------------


class GridInfo(Out):
    id: str
    source: str
    lat_deg: list[float] = Field(description="first and last node latitude, deg")
    lon_deg: list[float] = Field(description="first and last node longitude, deg")
    step_arcmin: float
    has_dg: bool


class GridUploaded(GridInfo):
    use: dict[str, str] = Field(description="the job parameters that use this grid")


# --- pipelines, jobs, views ---------------------------------------------------------------------


class PipelineParam(Out):
    name: str
    kind: str = Field(description="float, int, bool, str, floats or paths")
    default: Any
    help: str
    label: str = Field(description="what a form shows, e.g. 'LDV mounting pitch η_L'")
    unit: str = Field(description="the value's unit, e.g. '°'; empty for dimensionless, choices and text")
    choices: list[Any] | None


class PipelineInfo(Out):
    name: str
    description: str
    multi_input: bool
    parameters: list[PipelineParam]
    schema_: JSON = Field(alias="schema", description="JSON schema of the parameters")
    applicable: bool | None = Field(None, description="only with ?log_id=: whether it applies to that log")
    reasons: list[str] | None = Field(None, description="only with ?log_id=: why it does not apply")


class ViewInfo(Out):
    name: str
    pipeline: str
    title: str = Field(description="what the figure shows")
    units: str = Field(description="units of the y axis")
    files: list[str] = Field(description="the job's result files the figure reads")


class Job(Out):
    id: int
    pipeline: str
    log_ids: list[int]
    parameters: JSON = Field(description="the parameters given (defaults not filled in)")
    status: str = Field(description="queued, running, succeeded, failed or cancelled")
    stage: str | None
    progress: float | None = Field(description="percent")
    attempts: int
    cancel_requested: bool
    error: str | None
    created_at: str | None
    started_at: str | None
    finished_at: str | None
    heartbeat_at: str | None
    summary: JSON | None = Field(description="summary.json of a finished job")
    stage_log: list[JSON]


class JobStarted(Job):
    resolved_parameters: JSON = Field(description="every parameter with its value, defaults included")


class JobInput(Out):
    log_id: int
    name: str
    bundle_sha256: str
    files: list[FileInfo]


class Headline(Out):
    key: str = Field(description="the figure's path in summary.json, e.g. 'noise_floor.total_mgal'")
    label: str
    value: Any
    unit: str
    text: str = Field(description="the value as people read it, with its unit")
    specifiable: bool = Field(description="a user's specification may bound it: |value| ≤ specification passes")


class Label(Out):
    label: str
    unit: str


class JobDetail(Job):
    inputs: list[JobInput]
    warnings: list[str]
    views: list[ViewInfo] = Field(description="the figures of this job's pipeline (GET …/views/{name})")
    headlines: list[Headline] = Field(description="the figures the job page and the survey report lead with")
    labels: dict[str, Label] = Field(description="a human label and unit for every key of the summary and parameters")


class ResultFile(Out):
    name: str
    size_bytes: int


class Names(Out):
    fix_quality: dict[str, str] = Field(description="GGA fix quality code → its name, e.g. '4' → '4 RTK fixed'")


class Basemap(Out):
    tile_url: str | None = Field(description="raster tile URL with {z}, {x}, {y}; null: plain maps in metres")
    attribution: str = Field(description="the tiles' attribution, shown on the map")


class Figure(Out):
    data: list[JSON] = Field(description="Plotly traces")
    layout: JSON = Field(description="Plotly layout")


class CompareStat(Out):
    job: int
    line: str = Field(description="a line name, or 'all'")
    n_common: int
    mean_mgal: float | None
    std_mgal: float | None
    rms_mgal: float | None
    max_abs_mgal: float | None
    distance_range_m: list[float] | None = None


class Comparison(Out):
    reference_job: int
    jobs: list[int]
    statistics: list[CompareStat]


class LeftoverCounts(Out):
    staging_folders: int = Field(description="staging folders of uploads (<data dir>/tmp)")
    part_blobs: int = Field(description="blob files being written (.part)")
    unreferenced_blobs: int = Field(0, description="complete blob files no row names (SQLite's folder)")
    bytes: int


class StorageOut(Out):
    stored_bytes: int = Field(description="bytes of the stored logs' original files")
    leftovers_removed: LeftoverCounts = Field(
        description="left by stopped processes (killed mid-upload), removed since this server started"
    )
    last_clean_at: float | None = Field(description="Unix time (s) of the last clean-up")
    leftovers_now: LeftoverCounts = Field(description="uploads and blob writes in progress now (not data)")
