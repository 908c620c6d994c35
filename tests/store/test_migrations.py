"""Migration 0005 on a database that already holds data: nothing lost, ids not reused afterwards."""

from sqlalchemy import text

from ldvsurvey.store.db import MIGRATIONS_DIR, get_engine, upgrade_head


def test_upgrade_keeps_rows_and_stops_id_reuse(tmp_path):
    from alembic import command
    from alembic.config import Config

    url = f"sqlite:///{tmp_path / 'old.db'}"
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("sqlalchemy.url", url)
    eng = get_engine(url)
    with eng.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0004")
    with eng.begin() as c:
        c.execute(
            text(
                "INSERT INTO logs (id, sha256, name, platform, ldv_kind, imu_rotating, survey_date, t_start_s,"
                " t_end_s, duration_s, has_gnss, size_bytes, manifest, quality, created_at) VALUES "
                "(1, 'a', 'n', 'vehicle', '2d', 0, '2023-01-01', 0, 1, 1, 0, 1, '{}', '{}', '2023-01-01'),"
                "(2, 'b', 'n', 'vehicle', '2d', 0, '2023-01-01', 0, 1, 1, 0, 1, '{}', '{}', '2023-01-01')"
            )
        )
        c.execute(
            text(
                "INSERT INTO log_files (log_id, name, sha256, size_bytes, content) VALUES (2, 'imu.csv', 'x', 1, X'00')"
            )
        )
        for i in (1, 2, 3):
            c.execute(
                text(
                    "INSERT INTO jobs (id, pipeline, log_ids, parameters, status, stage, progress, attempts,"
                    f" cancel_requested, created_at) VALUES ({i}, 'height', '[2]', '{{}}', 'succeeded', 'done',"
                    " 100, 1, 0, '2023-01-01')"
                )
            )
        c.execute(text("INSERT INTO job_files (job_id, name, size_bytes, content) VALUES (3, 'h.csv', 1, X'00')"))
    upgrade_head(url)
    with eng.begin() as c:
        assert c.execute(text("SELECT count(*) FROM log_files")).scalar() == 1  # children survived
        assert c.execute(text("SELECT count(*) FROM job_files")).scalar() == 1
        assert c.execute(text("PRAGMA foreign_keys")).scalar() == 1
        c.execute(text("DELETE FROM jobs WHERE id = 3"))
        c.execute(text("DELETE FROM logs WHERE id = 2"))
    with eng.begin() as c:
        c.execute(
            text(
                "INSERT INTO jobs (pipeline, log_ids, parameters, status, stage, progress, attempts,"
                " cancel_requested, created_at) VALUES ('height', '[1]', '{}', 'queued', 'q', 0, 0, 0,"
                " '2023-01-01')"
            )
        )
        assert c.execute(text("SELECT max(id) FROM jobs")).scalar() == 4
        c.execute(
            text(
                "INSERT INTO logs (sha256, name, platform, ldv_kind, imu_rotating, survey_date, t_start_s,"
                " t_end_s, duration_s, has_gnss, size_bytes, manifest, quality, created_at) VALUES "
                "('c', 'n', 'vehicle', '2d', 0, '2023-01-01', 0, 1, 1, 0, 1, '{}', '{}', '2023-01-01')"
            )
        )
        assert c.execute(text("SELECT max(id) FROM logs")).scalar() == 3
        # the job files of the deleted job went with it (cascade still declared)
        assert c.execute(text("SELECT count(*) FROM job_files")).scalar() == 0
