"""The review server's credential (issue 20 item 11): a Jupyter-style token in the URL, a cookie for the page's
own requests, and an Origin check, so neither another local process nor a page of another site can paint.
"""
import base64
import http.client
import os
from urllib.parse import urlsplit

import numpy as np
import pytest

pytest.importorskip("trame_vtk")

from plantvr.documents.labels import Segmentation
from plantvr.adapters.vtk_isosurface import extract_isosurface


def _sphere(n=24):
    g = np.mgrid[:n, :n, :n].astype(np.float32) - (n - 1) / 2
    return (np.sqrt((g ** 2).sum(0)) < n / 3).astype(np.uint8) * 200


@pytest.fixture(scope="module")
def app():
    from plantvr.view.vine_app import VineReviewApp
    s = extract_isosurface(_sphere(), 100.0)
    a = VineReviewApp(Segmentation(s.vertices, s.faces, normals=s.normals), target_faces=2000,
                      window_size=(320, 240))
    a.start()
    yield a
    a.stop()


def _get(app, path, headers=None):
    c = http.client.HTTPConnection("127.0.0.1", app.port, timeout=10)
    c.request("GET", path, headers=headers or {})
    r = c.getresponse()
    body = r.read() if r.status != 101 else b""
    c.close()
    return r, body


def _ws(app, *, cookie=None, origin="same", query=""):
    """Status of a websocket upgrade of trame's ``/ws`` endpoint (101 = accepted)."""
    h = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
         "Sec-WebSocket-Key": base64.b64encode(os.urandom(16)).decode()}
    if origin == "same":
        h["Origin"] = f"http://127.0.0.1:{app.port}"
    elif origin is not None:
        h["Origin"] = origin
    if cookie:
        h["Cookie"] = cookie
    c = http.client.HTTPConnection("127.0.0.1", app.port, timeout=10)
    c.request("GET", "/ws" + query, headers=h)
    status = c.getresponse().status
    c.close()
    return status


def _cookie(app):
    r, _ = _get(app, "/" + "?" + urlsplit(app.url).query)
    assert r.status == 302 and r.getheader("Location") == "/index.html"        # the token leaves the address bar
    set_cookie = r.getheader("Set-Cookie")
    assert "HttpOnly" in set_cookie and "SameSite=Lax" in set_cookie
    return set_cookie.split(";")[0]


def test_url_carries_a_random_token(app):
    q = urlsplit(app.url).query
    assert q == f"token={app.token}" and len(app.token) >= 32
    assert set(app.token) <= set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_")


def test_http_without_token_or_with_a_wrong_one_is_refused(app):
    for path in ("/", "/index.html", "/index.html?token=wrong", "/?token=" + app.token[:-1] + "x"):
        r, body = _get(app, path)
        assert r.status == 403, path
        assert b"token" in body


def test_tokened_url_sets_a_cookie_that_serves_the_page(app):
    cookie = _cookie(app)
    r, body = _get(app, "/index.html", {"Cookie": cookie})
    assert r.status == 200 and b"<html" in body.lower()
    r, _ = _get(app, "/index.html", {"Cookie": cookie.split("=")[0] + "=nope"})
    assert r.status == 403
    r, _ = _get(app, "/index.html", {"Authorization": f"token {app.token}"})     # scripts: a header works too
    assert r.status == 200


def test_websocket_needs_the_cookie_and_the_page_origin(app):
    cookie = _cookie(app)
    assert _ws(app) == 403                                             # no credential: any local process
    assert _ws(app, cookie=cookie) == 101                              # the page itself
    assert _ws(app, cookie=cookie, origin="http://evil.example") == 403
    assert _ws(app, cookie=cookie, origin=f"http://localhost:{app.port + 1}") == 403
    assert _ws(app, origin="http://evil.example", query=f"?token={app.token}") == 403
    assert _ws(app, origin=None, query=f"?token={app.token}") == 101  # a script that knows the token


def test_foreign_host_header_is_refused(app):
    cookie = _cookie(app)
    r, _ = _get(app, "/index.html", {"Cookie": cookie, "Host": f"rebound.example:{app.port}"})
    assert r.status == 403


def test_access_guard_checks_its_arguments():
    from plantvr.view.vine_access import access_guard
    with pytest.raises(ValueError, match="token"):
        access_guard("short", 8080)
    with pytest.raises(ValueError, match="port"):
        access_guard("x" * 32, 0)
