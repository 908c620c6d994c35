"""SQLAlchemy 2 models. The schema itself is created by the Alembic migrations."""

from __future__ import annotations

import datetime as dt

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    Date,
    DateTime,
    Float,
    ForeignKey,
    Integer,
    LargeBinary,
    String,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


def utcnow() -> dt.datetime:
    """The current time, timezone-aware in UTC (the columns' default)."""
    return dt.datetime.now(dt.UTC)


class Base(DeclarativeBase):
    pass


class Log(Base):
    """One drive-log bundle."""

    __tablename__ = "logs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    __table_args__ = (
        UniqueConstraint("project_id", "sha256", name="uq_logs_project_sha256"),
        {"sqlite_autoincrement": True},
    )  # ids never reused

    sha256: Mapped[str] = mapped_column(String(64), nullable=False)
    project_id: Mapped[int | None] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), nullable=True)
    name: Mapped[str] = mapped_column(String(400), nullable=False, default="")
    platform: Mapped[str] = mapped_column(String(16), nullable=False)
    ldv_kind: Mapped[str] = mapped_column(String(16), nullable=False)
    imu_rotating: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    survey_date: Mapped[dt.date] = mapped_column(Date, nullable=False)
    t_start_s: Mapped[float] = mapped_column(Float, nullable=False)
    t_end_s: Mapped[float] = mapped_column(Float, nullable=False)
    duration_s: Mapped[float] = mapped_column(Float, nullable=False)
    has_gnss: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    size_bytes: Mapped[int] = mapped_column(BigInteger, nullable=False, default=0)
    manifest: Mapped[dict] = mapped_column(JSON, nullable=False)
    quality: Mapped[dict] = mapped_column(JSON, nullable=False)
    #: what the applicability checks know of the log (:func:`ldvsurvey.io.logfacts.log_facts`), found
    #: when it was stored; NULL for a row stored before (computed on first use, ``store.logs.facts_of``)
    facts: Mapped[dict | None] = mapped_column(JSON, nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)

    files: Mapped[list[LogFile]] = relationship(
        back_populates="log", cascade="all, delete-orphan", passive_deletes=True, lazy="raise"
    )
    arrays: Mapped[list[LogArray]] = relationship(
        back_populates="log", cascade="all, delete-orphan", passive_deletes=True, lazy="raise"
    )


class LogFile(Base):
    """An original file of a bundle, byte for byte: in the row (``content``) or, when large, a blob
    (``blob``: a file of the blob folder, or ``db:…`` chunks in ``blob_chunks``; see
    :mod:`ldvsurvey.store.blobs`)."""

    __tablename__ = "log_files"
    __table_args__ = (UniqueConstraint("log_id", "name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    log_id: Mapped[int] = mapped_column(ForeignKey("logs.id", ondelete="CASCADE"), nullable=False, index=True)
    name: Mapped[str] = mapped_column(String(255), nullable=False)
    sha256: Mapped[str] = mapped_column(String(64), nullable=False)
    size_bytes: Mapped[int] = mapped_column(BigInteger, nullable=False)
    inline: Mapped[bytes | None] = mapped_column("content", LargeBinary, nullable=True, deferred=True)
    blob: Mapped[str | None] = mapped_column(String(200), nullable=True)

    log: Mapped[Log] = relationship(back_populates="files")

    def __init__(self, content: bytes | None = None, **kw):
        super().__init__(inline=content, **kw)

    @property
    def content(self) -> bytes:
        """The file's bytes (read from the blob folder when it lives there)."""
        if self.blob is None:
            return self.inline
        from ldvsurvey.store.blobs import open_blob

        with open_blob(self, self.blob) as fh:
            return fh.read()


class LogArray(Base):
    """A parsed stream (``imu``, ``ldv``, ``gnss``) as Parquet: in the row (``parquet``) or a blob
    (``blob``, as :class:`LogFile`)."""

    __tablename__ = "log_arrays"
    __table_args__ = (UniqueConstraint("log_id", "name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    log_id: Mapped[int] = mapped_column(ForeignKey("logs.id", ondelete="CASCADE"), nullable=False, index=True)
    name: Mapped[str] = mapped_column(String(64), nullable=False)
    n_rows: Mapped[int] = mapped_column(Integer, nullable=False)
    parquet: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True, deferred=True)
    blob: Mapped[str | None] = mapped_column(String(200), nullable=True)

    log: Mapped[Log] = relationship(back_populates="arrays")


class BlobChunk(Base):
    """One piece of a blob kept in the database (PostgreSQL): the blob ``key`` (``db:…``, named by
    ``LogFile.blob`` / ``LogArray.blob``) is the concatenation of its chunks in ``seq`` order
    (:mod:`ldvsurvey.store.blobs`)."""

    __tablename__ = "blob_chunks"

    key: Mapped[str] = mapped_column(String(200), primary_key=True)
    seq: Mapped[int] = mapped_column(Integer, primary_key=True)
    data: Mapped[bytes] = mapped_column(LargeBinary, nullable=False)


class DovGridRow(Base):
    """A synthesized DOV grid (ξ, η, Δg on lat × lon nodes) cached by model, degree, step and area."""

    __tablename__ = "dov_grids"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    key: Mapped[str] = mapped_column(String(300), unique=True, nullable=False)
    source: Mapped[str] = mapped_column(String(300), nullable=False)
    n_lat: Mapped[int] = mapped_column(Integer, nullable=False)
    n_lon: Mapped[int] = mapped_column(Integer, nullable=False)
    parquet: Mapped[bytes] = mapped_column(LargeBinary, nullable=False)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)


class Job(Base):
    """A pipeline run: the source of truth for status, progress, heartbeat and attempts."""

    __tablename__ = "jobs"
    __table_args__ = {"sqlite_autoincrement": True}  # ids never reused

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    pipeline: Mapped[str] = mapped_column(String(32), nullable=False)
    log_ids: Mapped[list] = mapped_column(JSON, nullable=False)
    parameters: Mapped[dict] = mapped_column(JSON, nullable=False)
    status: Mapped[str] = mapped_column(String(16), nullable=False, default="queued", index=True)
    stage: Mapped[str] = mapped_column(String(200), nullable=False, default="queued")
    progress: Mapped[float] = mapped_column(Float, nullable=False, default=0.0)
    attempts: Mapped[int] = mapped_column(Integer, nullable=False, default=0)
    cancel_requested: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    error: Mapped[str | None] = mapped_column(String, nullable=True)
    summary: Mapped[dict | None] = mapped_column(JSON, nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)
    started_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    finished_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    heartbeat_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    user_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    #: [{"t_s": seconds since the attempt started, "stage": ..., "progress": percent}, ...]
    stage_log: Mapped[list | None] = mapped_column(JSON, nullable=True)


class JobFile(Base):
    """A result file of a job (summary.json or a CSV), exactly as the CLI writes it."""

    __tablename__ = "job_files"
    __table_args__ = (UniqueConstraint("job_id", "name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    job_id: Mapped[int] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), nullable=False, index=True)
    name: Mapped[str] = mapped_column(String(255), nullable=False)
    size_bytes: Mapped[int] = mapped_column(BigInteger, nullable=False)
    content: Mapped[bytes] = mapped_column(LargeBinary, nullable=False)


class User(Base):
    __tablename__ = "users"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    username: Mapped[str] = mapped_column(String(100), unique=True, nullable=False)
    password_hash: Mapped[str] = mapped_column(String(300), nullable=False)
    is_admin: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    is_demo: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    disabled: Mapped[bool] = mapped_column(Boolean, nullable=False, default=False)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)


class Project(Base):
    __tablename__ = "projects"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True, nullable=False)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)


class ProjectTie(Base):
    """A base station of a project: where it is (geodetic, ellipsoidal height) and its absolute gravity
    with 1-σ, entered once and offered to every gravity job of the project (``base_ties``)."""

    __tablename__ = "project_ties"
    __table_args__ = (UniqueConstraint("project_id", "name", name="uq_project_ties_project_name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), nullable=False, index=True)
    name: Mapped[str] = mapped_column(String(100), nullable=False)
    lat_deg: Mapped[float] = mapped_column(Float, nullable=False)
    lon_deg: Mapped[float] = mapped_column(Float, nullable=False)
    h_m: Mapped[float] = mapped_column(Float, nullable=False)
    g_mgal: Mapped[float] = mapped_column(Float, nullable=False)
    sigma_mgal: Mapped[float] = mapped_column(Float, nullable=False)
    note: Mapped[str] = mapped_column(String(500), nullable=False, default="")
    #: who entered it (None in open mode): the demo account changes only the ties it entered
    user_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)


class Membership(Base):
    __tablename__ = "memberships"

    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), primary_key=True)


class SessionRow(Base):
    __tablename__ = "sessions"

    token_hash: Mapped[str] = mapped_column(String(64), primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), nullable=False)
    csrf: Mapped[str] = mapped_column(String(64), nullable=False)
    expires_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False)


class ApiToken(Base):
    __tablename__ = "api_tokens"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    token_hash: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), nullable=False)
    name: Mapped[str] = mapped_column(String(100), nullable=False)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, default=utcnow)
    expires_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    last_used_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)


class LoginFailure(Base):
    """One failed login, counted per account and per client (shared by every API process)."""

    __tablename__ = "login_failures"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    key: Mapped[str] = mapped_column(String(300), nullable=False, index=True)
    at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), nullable=False, index=True)
