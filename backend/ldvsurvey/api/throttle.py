"""Login throttling per account and per client, with counters every API process shares.

Only failed logins count. The counters live in the database (table ``login_failures``) or, when
``LDVSURVEY_REDIS_URL`` is set, in Redis. The client is the TCP peer; ``X-Forwarded-For`` is read
only when the peer is one of ``LDVSURVEY_TRUSTED_PROXIES``.
"""

from __future__ import annotations

import ipaddress
import logging
import math
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


#: the one key of every request whose peer a server in front replaced from ``X-Forwarded-For``
#: without being told to by ``LDVSURVEY_TRUSTED_PROXIES``: its real peer is unknown, so all such
#: requests share one count (rotating the header gives no fresh address)
UNVERIFIED_CLIENT = "forwarded-unverified"

_log = logging.getLogger("ldvsurvey.throttle")
_warned = False


def _hop_host(hop: str) -> str:
    """The address of one ``X-Forwarded-For`` hop, without a port (``1.2.3.4:80``, ``[::1]:80``)."""
    hop = hop.strip()
    if hop.startswith("[") and "]" in hop:
        return hop[1 : hop.index("]")]
    if hop.count(":") == 1:
        return hop.split(":", 1)[0]
    return hop


def client_address(request: Request, settings) -> str:
    """The client's address for counting: the peer, or the right-most untrusted hop of
    ``X-Forwarded-For`` when the peer is one of ``settings.trusted_proxies``.

    A server in front of the app may already have replaced the peer with a hop of the header
    (uvicorn does by default for requests from 127.0.0.1: ``--proxy-headers``); the real peer is then
    lost. Such a request (its peer is one of the header's hops) counts under its own address only
    when a proxy is configured and that address is the one the rule above picks; otherwise it
    counts under :data:`UNVERIFIED_CLIENT`, and a warning says how to start the server.
    """
    peer = request.client.host if request.client else "unknown"
    nets = _networks(settings.trusted_proxies)
    hops = [_hop_host(h) for h in request.headers.get("x-forwarded-for", "").split(",") if h.strip()]
    if nets and _trusted(peer, nets):
        for hop in reversed(hops):
            if not _trusted(hop, nets):
                return hop
        return hops[0] if hops else peer
    if peer not in hops:
        return peer
    if nets and next((h for h in reversed(hops) if not _trusted(h, nets)), None) == peer:
        return peer  # the server in front applied our rule (it must trust the same proxies)
    global _warned
    if not _warned:
        _warned = True
        _log.warning(
            "the server in front of the app replaced the client address from X-Forwarded-For "
            "(LDVSURVEY_TRUSTED_PROXIES=%r): all such requests share one login-failure count. Start uvicorn "
            "with --no-proxy-headers (ldv-survey serve and the image do), or set --forwarded-allow-ips "
            "to LDVSURVEY_TRUSTED_PROXIES",
            settings.trusted_proxies,
        )
    return UNVERIFIED_CLIENT


class LoginThrottle:
    """``attempt(account, client)`` before checking a password (counted as a failure), ``succeeded`` after
    a right one."""

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
        """The counter keys of a login: the account (case-folded) and the client's address."""
        return f"account:{account.strip().lower()}", f"client:{client}"

    def _times(self, key: str) -> list[float]:
        """The times (Unix s, oldest first) of the key's failures within the window."""
        if self.redis is not None:
            k = self.prefix + key
            self.redis.zremrangebyscore(k, 0, time.time() - self.window_s)
            return [float(t) for _, t in self.redis.zrange(k, 0, -1, withscores=True)]
        with session_scope(self.url) as s:
            return ustore.login_failure_times(s, key, self.window_s)

    def _wait_s(self, times: list[float], limit: int) -> int:
        """Whole seconds until fewer than ``limit`` of ``times`` are inside the window (>= 1)."""
        oldest_to_expire = times[len(times) - limit]
        return max(1, math.ceil(oldest_to_expire + self.window_s - time.time()))

    def blocked(self, account: str, client: str, own: int = 0) -> tuple[str, int] | None:
        """A reason to refuse the attempt without looking at the password and the seconds to wait
        before the next attempt can count (``Retry-After``), or None. ``own``: entries of this
        attempt already among the counted."""
        ka, kc = self.keys(account, client)
        times = self._times(ka)
        if len(times) - own >= self.max_account:
            return (
                f"too many failed logins for this account: wait up to {self.window_s / 60:.0f} min "
                "or ask an admin to set a new password",
                self._wait_s(times, self.max_account),
            )
        times = self._times(kc)
        if len(times) - own >= self.max_client:
            return (
                f"too many failed logins from your address: wait up to {self.window_s / 60:.0f} min",
                self._wait_s(times, self.max_client),
            )
        return None

    def attempt(self, account: str, client: str) -> tuple[tuple[str, int] | None, object]:
        """Count a login attempt as a failure before its password is checked, so that concurrent
        guesses count each other (checking first and counting after let 20 simultaneous guesses
        through a limit of 5).

        Returns ``(refusal, ticket)``: ``refusal`` is ``(reason, Retry-After seconds)`` when the
        attempt is refused without looking at the password (it then does not count), else None;
        ``ticket`` names the attempt's entries for :meth:`succeeded`. The entries are committed
        before the count, so the k-th attempt to count sees at least k: at most the limit get through.
        """
        refused = self.blocked(account, client)
        if refused:
            return refused, None
        ticket = self._record(self.keys(account, client))
        refused = self.blocked(account, client, own=1)
        if refused:
            self._forget(ticket)
        return refused, ticket

    def _record(self, keys: tuple[str, str]) -> object:
        if self.redis is not None:
            member, now = uuid.uuid4().hex, time.time()
            with self.redis.pipeline() as p:  # MULTI/EXEC
                for k in keys:
                    p.zadd(self.prefix + k, {member: now})
                    p.expire(self.prefix + k, int(self.window_s) + 1)
                p.execute()
            return [(self.prefix + k, member) for k in keys]
        with session_scope(self.url) as s:
            ids = ustore.record_login_failure(s, list(keys))
            ustore.prune_login_failures(s, self.window_s)
        return ids

    def _forget(self, ticket) -> None:
        if self.redis is not None:
            with self.redis.pipeline() as p:
                for k, member in ticket:
                    p.zrem(k, member)
                p.execute()
            return
        with session_scope(self.url) as s:
            ustore.forget_login_failure_ids(s, ticket)

    def succeeded(self, account: str, client: str, ticket) -> None:
        """A right password: the attempt was no failure, and the account's failures are cleared
        (not the client's)."""
        ka, _ = self.keys(account, client)
        self._forget(ticket)
        if self.redis is not None:
            self.redis.delete(self.prefix + ka)
            return
        with session_scope(self.url) as s:
            ustore.forget_login_failures(s, [ka])
