"""Who may drive the preview, and with what values: the page's server refuses a websocket (or page)
request from another origin, asks for a per-run token where it listens beyond this machine, and every
control's value is clamped to the range the CLI enforces before it reaches the simulation.

A page on any site can open a websocket to ``127.0.0.1``; only its ``Origin`` header tells it apart, so
the check compares the Origin with the Host the request was sent to (and, on loopback, the Host with
loopback names: a rebound DNS name is refused too). Where the preview listens on another address, the
printed URL carries ``?token=…``; the page load that brings it sets a same-site cookie, which the page's
own websocket then sends.
"""

from __future__ import annotations

import hmac
import http
import ipaddress
import math
import secrets
import urllib.parse
from contextlib import contextmanager

#: The cookie that carries the token from the page load to its websocket.
COOKIE = "physomni_preview"
LOOPBACK_NAMES = {"localhost", "127.0.0.1", "::1"}


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Guard:
    """The checks for one preview server bound to ``host``; ``token`` is None on loopback."""

    def __init__(self, host: str):
        self.host = host
        self.token = None if is_loopback(host) else secrets.token_urlsafe(18)

    def url(self, port: int) -> str:
        shown = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{shown}:{port}/" + (f"?token={self.token}" if self.token else "")

    def refusal(self, headers, path: str) -> str | None:
        """Why a request (its headers and path with query) may not reach the server, or None."""
        host = headers.get("Host") or ""
        hostname = urllib.parse.urlsplit(f"//{host}").hostname or ""
        if self.token is None and not is_loopback(hostname):
            return f"Host {host!r} is not this machine's loopback address"
        origin = headers.get("Origin")
        if origin is not None:
            o = urllib.parse.urlsplit(origin)
            if o.scheme not in ("http", "https") or o.netloc.lower() != host.lower():
                return f"Origin {origin!r} is another origin than the preview's"
        if self.token is not None and not (self._query_token(path) or self._cookie_token(headers)):
            return "the preview's token is missing or wrong: open the URL it printed"
        return None

    def _query_token(self, path: str) -> bool:
        given = urllib.parse.parse_qs(urllib.parse.urlsplit(path).query).get("token", [""])[0]
        return bool(given) and hmac.compare_digest(given, self.token)

    def _cookie_token(self, headers) -> bool:
        for header in headers.get_all("Cookie") if hasattr(headers, "get_all") else [headers.get("Cookie", "")]:
            for part in (header or "").split(";"):
                name, _, value = part.strip().partition("=")
                if name == COOKIE and value and hmac.compare_digest(value, self.token):
                    return True
        return False

    def wrap(self, process_request):
        """A websockets ``process_request`` that refuses what :meth:`refusal` refuses, then hands on."""

        def guarded(connection, request):
            why = self.refusal(request.headers, request.path)
            if why is not None:
                return connection.respond(http.HTTPStatus.FORBIDDEN, f"refused: {why}\n")
            response = process_request(connection, request) if process_request is not None else None
            if response is not None and self.token is not None and self._query_token(request.path):
                response.headers["Set-Cookie"] = f"{COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"
            return response

        return guarded


@contextmanager
def guarded_server(guard: Guard):
    """While viser starts its server inside this block, every connection to it passes ``guard`` first.

    viser has no option for it; its server is ``websockets.asyncio.server.serve`` with a
    ``process_request`` of its own (the page's files), which the guard wraps.
    """
    import websockets.asyncio.server as ws

    original = ws.serve

    def serve(*args, **kwargs):
        kwargs["process_request"] = guard.wrap(kwargs.get("process_request"))
        return original(*args, **kwargs)

    ws.serve = serve
    try:
        yield
    finally:
        ws.serve = original


def clamp(value, lo: float, hi: float) -> float | None:
    """``value`` as a float within ``[lo, hi]``; None (ignore it) where it is no finite number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(v):
        return None
    return min(max(v, lo), hi)


def param_range(key: str) -> tuple[float, float]:
    """The catalog's range of a material parameter (density, friction, restitution, …)."""
    from ..materials.catalog import PARAMS

    p = PARAMS["dynamic_friction" if key == "friction" else key]  # the preview's one friction is both
    return float(p.lo), float(p.hi)


def gravity_range() -> tuple[float, float]:
    from ..physics.checks import MAX_GRAVITY

    return 0.0, MAX_GRAVITY


def field_strength_range() -> tuple[float, float]:
    from ..fields import FIELD_RANGES

    lo, hi, _ = FIELD_RANGES["strength"]
    return float(lo), float(hi)
