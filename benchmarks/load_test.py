"""Load test of the read endpoints on loopback: locust headless, 50 users, 60 s (bounded, stops by itself).

Starts its own server (SQLite, a temporary data directory) with one stored log and one finished job,
then prints p50/p99 per endpoint. Run: .venv/bin/python benchmarks/load_test.py [seconds] [users]
"""

import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(seconds=60, users=50):
    from _server import start

    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    srv, base, data = start(
        ["-m", "uvicorn", "ldvsurvey.api.asgi:app", "--port", "{port}", "--workers", "2", "--log-level", "warning"],
        {"LDVSURVEY_AUTH_ENABLED": "false"},
    )
    try:
        files = bundle_files(simulate(catalog.height(minutes=12.0, length_m=3000.0), seed=1))
        log_id = httpx.post(
            base + "/api/logs", files=[("files", (n, d)) for n, d in files.items()], timeout=120
        ).json()["id"]
        job = httpx.post(f"{base}/api/logs/{log_id}/jobs", json={"pipeline": "height"}).json()["id"]
        while httpx.get(f"{base}/api/jobs/{job}").json()["status"] not in ("succeeded", "failed"):
            time.sleep(0.5)
        locustfile = data / "locustfile.py"
        locustfile.write_text(f"""
from locust import HttpUser, task, between
class Reader(HttpUser):
    wait_time = between(0.1, 0.5)
    @task(3)
    def logs(self): self.client.get("/api/logs", name="/api/logs")
    @task(2)
    def log(self): self.client.get("/api/logs/{log_id}", name="/api/logs/{{id}}")
    @task(2)
    def job(self): self.client.get("/api/jobs/{job}", name="/api/jobs/{{id}}")
    @task(1)
    def view(self): self.client.get("/api/jobs/{job}/views/height?points=2000", name="/api/jobs/{{id}}/views/height")
""")
        subprocess.run(
            [
                sys.executable,
                "-m",
                "locust",
                "-f",
                str(locustfile),
                "--headless",
                "-u",
                str(users),
                "-r",
                "10",
                "-t",
                f"{seconds}s",
                "--host",
                base,
                "--only-summary",
                "--csv",
                str(data / "load"),
            ],
            check=False,
        )
        import csv

        with open(data / "load_stats.csv") as fh:
            print(f"\n{'endpoint':40s} {'requests':>9s} {'fails':>6s} {'p50 ms':>7s} {'p99 ms':>7s}")
            for row in csv.DictReader(fh):
                print(
                    f"{row['Name']:40s} {row['Request Count']:>9s} {row['Failure Count']:>6s} "
                    f"{row['50%']:>7s} {row['99%']:>7s}"
                )
    finally:
        srv.terminate()
        srv.wait()


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
