"""Security headers on every response (pages, API, docs, static files)."""

from __future__ import annotations


def csp(tile_origin: str | None = None) -> str:
    """The policy: no inline script anywhere (the pages and /docs load their scripts from files of
    this origin); inline styles are allowed because Plotly and Swagger UI set element styles. With a
    basemap (``LDVSURVEY_BASEMAP_TILE_URL``) its tiles' origin is admitted as an image and fetch
    source, and nothing else."""
    extra = f" {tile_origin}" if tile_origin else ""
    return (
        f"default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:{extra}; "
        f"font-src 'self' data:; connect-src 'self'{extra}; worker-src 'self' blob:; object-src 'none'; "
        "base-uri 'self'; form-action 'self'; frame-ancestors 'none'"
    )


CSP = csp()
HEADERS = [
    (b"content-security-policy", CSP.encode()),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
    (b"x-frame-options", b"DENY"),
    (b"cross-origin-opener-policy", b"same-origin"),
    (b"permissions-policy", b"camera=(), microphone=(), geolocation=()"),
]


class SecurityHeaders:
    """ASGI middleware adding :data:`HEADERS` (unless the response set one itself)."""

    def __init__(self, app, tile_origin: str | None = None):
        self.app = app
        self.headers = [(b"content-security-policy", csp(tile_origin).encode())] + HEADERS[1:]

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)

        async def with_headers(message):
            if message["type"] == "http.response.start":
                have = {k.lower() for k, _ in message.get("headers", [])}
                message["headers"] = list(message.get("headers", [])) + [h for h in self.headers if h[0] not in have]
            await send(message)

        await self.app(scope, receive, with_headers)
