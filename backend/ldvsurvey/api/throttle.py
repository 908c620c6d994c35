"""Login throttling per account and per client, with counters every API process shares.

Only failed logins count. The counters live in the database (table ``login_failures``) or, when
``LDVSURVEY_REDIS_URL`` is set, in Redis. The client is the TCP peer; ``X-Forwarded-For`` is read
only when the peer is one of ``LDVSURVEY_TRUSTED_PROXIES``.
"""

from __future__ import annotations

import ipaddress
import time
import uuid

from fastapi import Request

from ldvsurvey.store import users as ustore
from ldvsurvey.store.db import session_scope


def _networks(spec: str) -> list:
    out = []
    for part in (spec or "").replace(";", ",").split(","):
        part = part.strip()
        if part:
            out.append(ipaddress.ip_network(part, strict=False))
    return out


def _trusted(addr: str, nets: list) -> bool:
    try:
        ip = ipaddress.ip_address(addr)
    except ValueError:
        return False
    return any(ip in n for n in nets)


def client_address(request: Request, settings) -> str:
    """The client's address: the peer, or the right-most untrusted hop of ``X-Forwarded-For``
    when the peer is one of ``settings.trusted_proxies``."""
    peer = request.client.host if request.client else "unknown"
    nets = _networks(settings.trusted_proxies)
    if not nets or not _trusted(peer, nets):
        return peer
    hops = [h.strip() for h in request.headers.get("x-forwarded-for", "").split(",") if h.strip()]
    for hop in reversed(hops):
        if not _trusted(hop, nets):
            return hop
    return hops[0] if hops else peer


class LoginThrottle:
    """``blocked(account, client)`` before checking a password, ``failed``/``succeeded`` after."""

    def __init__(self, database_url: str, settings):
        self.url = database_url
        self.window_s = settings.login_window_s
        self.max_account = settings.login_failures_per_account
        self.max_client = settings.login_failures_per_client
        self.redis = None
        if settings.redis_url:
            import hashlib

            import redis

            self.redis = redis.Redis.from_url(settings.redis_url)
            # deployments (databases) sharing one Redis keep separate counters
            self.prefix = f"ldvs:loginfail:{hashlib.sha256(database_url.encode()).hexdigest()[:12]}:"

    @staticmethod
    def keys(account: str, client: str) -> tuple[str, str]:
        return f"account:{account.strip().lower()}", f"client:{client}"

    def _count(self, key: str) -> int:
        if self.redis is not None:
            k = self.prefix + key
            self.redis.zremrangebyscore(k, 0, time.time() - self.window_s)
            return int(self.redis.zcard(k))
        with session_scope(self.url) as s:
            return ustore.login_failures(s, key, self.window_s)

    def blocked(self, account: str, client: str) -> str | None:
        """A reason to refuse the attempt without looking at the password, or None."""
        ka, kc = self.keys(account, client)
        if self._count(ka) >= self.max_account:
            return (
                f"too many failed logins for this account: wait up to {self.window_s / 60:.0f} min "
                "or ask an admin to set a new password"
            )
        if self._count(kc) >= self.max_client:
            return f"too many failed logins from your address: wait up to {self.window_s / 60:.0f} min"
        return None

    def failed(self, account: str, client: str) -> None:
        keys = self.keys(account, client)
        if self.redis is not None:
            now = time.time()
            with self.redis.pipeline() as p:
                for k in keys:
                    p.zadd(self.prefix + k, {uuid.uuid4().hex: now})
                    p.expire(self.prefix + k, int(self.window_s) + 1)
                p.execute()
            return
        with session_scope(self.url) as s:
            ustore.record_login_failure(s, list(keys))
            ustore.prune_login_failures(s, self.window_s)

    def succeeded(self, account: str, client: str) -> None:
        """A right password clears the account's failures (not the client's)."""
        ka, _ = self.keys(account, client)
        if self.redis is not None:
            self.redis.delete(self.prefix + ka)
            return
        with session_scope(self.url) as s:
            ustore.forget_login_failures(s, [ka])
