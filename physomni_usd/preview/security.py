"""Who may drive the preview, and with what values: the page's server refuses a websocket (or page)
request from another origin, asks for a per-run token where it listens beyond this machine, and every
control's value is clamped to the range the CLI enforces before it reaches the simulation.

A page on any site can open a websocket to ``127.0.0.1``; only its ``Origin`` header tells it apart, so
the check compares the Origin with the Host the request was sent to (and, on loopback, the Host with
loopback names: a rebound DNS name is refused too). Where the preview listens on another address, the
printed URL carries ``?token=…``; the page load that brings it sets a same-site cookie, which the page's
own websocket then sends. The studio's ``http.server`` puts every request through the same
:meth:`Guard.refusal` under a name (and cookie) of its own, so that the studio's token and the token of the
preview it starts, on the next port of the same host, do not overwrite each other's cookie.
"""

from __future__ import annotations

import hmac
import http
import ipaddress
import math
import secrets
import urllib.parse
from contextlib import contextmanager

LOOPBACK_NAMES = {"localhost", "127.0.0.1", "::1"}


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _same(given: str, token: str) -> bool:
    """Whether ``given`` is ``token``, in constant time; as bytes, since ``hmac.compare_digest`` raises on a
    non-ASCII str (a header's or a %-escaped query's, which a client chooses)."""
    return bool(given) and hmac.compare_digest(given.encode("utf-8", "surrogateescape"), token.encode())


class Guard:
    """The checks for one server bound to ``host``; ``token`` is None on loopback. ``name`` is the server's
    in its refusals, and its cookie's name (``physomni_<name>``)."""

    def __init__(self, host: str, name: str = "preview"):
        self.host = host
        self.name = name
        self.cookie = f"physomni_{name}"
        self.token = None if is_loopback(host) else secrets.token_urlsafe(18)

    def url(self, port: int) -> str:
        shown = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{shown}:{port}/" + (f"?token={self.token}" if self.token else "")

    def refusal(self, headers, path: str) -> str | None:
        """Why a request (its headers and path with query) may not reach the server, or None."""
        host = headers.get("Host") or ""
        try:
            hostname = urllib.parse.urlsplit(f"//{host}").hostname or ""
        except ValueError:  # an unclosed [ : no address at all, and not worth a traceback
            hostname = ""
        if self.token is None and not is_loopback(hostname):
            return f"Host {host!r} is not this machine's loopback address"
        origin = headers.get("Origin")
        if origin is not None:
            try:
                o = urllib.parse.urlsplit(origin)
            except ValueError:
                o = urllib.parse.urlsplit("")
            if o.scheme not in ("http", "https") or o.netloc.lower() != host.lower():
                return f"Origin {origin!r} is another origin than the {self.name}'s"
        if self.token is not None and not (self._query_token(path) or self._cookie_token(headers)):
            return f"the {self.name}'s token is missing or wrong: open the URL it printed"
        return None

    def set_cookie(self, path: str) -> str | None:
        """The ``Set-Cookie`` value for the response to a request whose URL brought the token, else None."""
        if self.token is None or not self._query_token(path):
            return None
        return f"{self.cookie}={self.token}; Path=/; HttpOnly; SameSite=Strict"

    def _query_token(self, path: str) -> bool:
        given = urllib.parse.parse_qs(urllib.parse.urlsplit(path).query).get("token", [""])[0]
        return _same(given, self.token)

    def _cookie_token(self, headers) -> bool:
        # websockets' get_all gives [] where there is none, http.server's (email's) None
        for header in (headers.get_all("Cookie") if hasattr(headers, "get_all") else [headers.get("Cookie")]) or []:
            for part in (header or "").split(";"):
                name, _, value = part.strip().partition("=")
                if name == self.cookie and _same(value, self.token):
                    return True
        return False

    def wrap(self, process_request):
        """A websockets ``process_request`` that refuses what :meth:`refusal` refuses, then hands on."""

        def guarded(connection, request):
            why = self.refusal(request.headers, request.path)
            if why is not None:
                return connection.respond(http.HTTPStatus.FORBIDDEN, f"refused: {why}\n")
            response = process_request(connection, request) if process_request is not None else None
            cookie = self.set_cookie(request.path)
            if response is not None and cookie is not None:
                response.headers["Set-Cookie"] = cookie
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
