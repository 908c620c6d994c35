"""ASGI entry for process managers (settings from the environment)::

    uvicorn ldvsurvey.api.asgi:app --workers N --no-proxy-headers

The app reads ``X-Forwarded-For`` itself, only from ``LDVSURVEY_TRUSTED_PROXIES``
(:func:`ldvsurvey.api.throttle.client_address`); a server that replaces the client address from the
header first (uvicorn's default for 127.0.0.1) is detected and its requests share one login count.
"""

from ldvsurvey.api.app import create_app

app = create_app()
