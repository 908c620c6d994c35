# ldv-survey application image (api and worker). The install steps are the README's own: scripts/setup.sh.
FROM python:3.11-slim-bookworm
RUN apt-get update && apt-get install -y --no-install-recommends gcc curl && rm -rf /var/lib/apt/lists/*
WORKDIR /app
COPY . /app
RUN ./scripts/setup.sh
ENV PATH="/app/.venv/bin:${PATH}" \
    LDVSURVEY_DATA_DIR=/data
VOLUME ["/data"]
EXPOSE 8000
CMD ["uvicorn", "ldvsurvey.api.asgi:app", "--host", "0.0.0.0", "--port", "8000", "--workers", "4", "--no-proxy-headers"]
