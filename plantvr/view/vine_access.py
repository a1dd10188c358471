"""Access to the ViNE review page: the token guard in front of every route, a free local port and the server's
thread.

:func:`access_guard` is the aiohttp middleware :class:`~plantvr.view.vine_app.VineReviewApp` installs when
trame binds its server (Jupyter-style token, cookie, ``Origin`` and ``Host`` checks); :func:`serve_in_thread`
runs the server in a daemon thread and returns once it accepts connections.
"""
from __future__ import annotations

import asyncio
import hmac
import socket
import threading
import time
from urllib.parse import urlencode

from plantvr._validation import check_int

__all__ = ["access_guard", "serve_in_thread"]


_LOOPBACK = ("127.0.0.1", "localhost", "[::1]")


def access_guard(token: str, port: int, host: str = "127.0.0.1"):
    """An aiohttp middleware that admits only requests carrying ``token``, from the page's own origin.

    Like Jupyter's: the URL the server prints carries ``?token=...``; a request with it (compared in constant
    time) gets an HTTP-only cookie for this port (``SameSite=Lax``) and, for the page itself, a redirect to the
    same URL without the token, so later requests (page assets, the websocket, a reload) authenticate by
    cookie. Every other request is refused with 403: no token or cookie (any local process), a foreign
    ``Origin`` header (a page of another site trying the websocket or a form post), or, when listening on a
    loopback address, a ``Host`` header naming another host (DNS rebinding).

    Parameters
    ----------
    token : str
        The secret, at least 16 characters.
    port : int
        The port served (names the cookie and the allowed origins).
    host : str
        The interface listened on.
    """
    from aiohttp import web
    if not isinstance(token, str) or len(token) < 16:
        raise ValueError("token must be a string of at least 16 characters")
    port = check_int("port", port, 1, 65535)
    cookie = f"plantvr_vine_{port}"
    loopback = host in (*_LOOPBACK, "::1")
    hosts = {f"{h}:{port}" for h in (*_LOOPBACK, host if ":" not in host else f"[{host}]")}

    def refuse(why: str):
        return web.Response(status=403, text=f"plantvr segment: forbidden: {why}\n")

    def same(a: str | None) -> bool:
        return a is not None and hmac.compare_digest(a.encode(), token.encode())

    @web.middleware
    async def guard(request, handler):
        host_hdr = request.headers.get("Host", "")
        if loopback and host_hdr not in hosts:
            return refuse(f"unexpected Host header {host_hdr!r}")
        origin = request.headers.get("Origin")
        if origin is not None and origin not in {f"http://{h}" for h in (hosts if loopback else {host_hdr})}:
            return refuse(f"requests from origin {origin!r} are not allowed")
        given = request.query.get("token")
        auth = request.headers.get("Authorization", "")
        ok = same(given) or same(request.cookies.get(cookie)) or (auth.startswith("token ") and same(auth[6:]))
        if not ok:
            return refuse("open the URL printed by plantvr segment, with its ?token=...")
        if given is not None and request.path in ("/", "/index.html") \
                and request.headers.get("Upgrade", "").lower() != "websocket":
            rest = [(k, v) for k, v in request.query.items() if k != "token"]
            resp = web.Response(status=302, headers={"Location": "/index.html" + ("?" + urlencode(rest) if rest else "")})
            resp.set_cookie(cookie, token, httponly=True, samesite="Lax", path="/")
            return resp
        resp = await handler(request)
        if given is not None and not resp.prepared:
            resp.set_cookie(cookie, token, httponly=True, samesite="Lax", path="/")
        return resp

    return guard


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def serve_in_thread(server, host: str, port: int, timeout_s: float = 30.0, **kw) -> threading.Thread:
    """Start the trame ``server`` in a daemon thread (its own event loop) listening on ``host:port``; returns the
    thread once a connection is accepted, raises RuntimeError after ``timeout_s``."""
    def run():
        asyncio.set_event_loop(asyncio.new_event_loop())
        server.start(thread=True, host=host, port=port, **kw)
    thread = threading.Thread(target=run, name="vine-trame", daemon=True)
    thread.start()
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        try:
            with socket.create_connection((host, port), timeout=0.2):
                return thread
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"trame server did not start on {host}:{port}")
