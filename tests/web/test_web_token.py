"""The key of an exposed server (issue 67): the bind decides (a loopback bind asks no key
unless given one, a ``0.0.0.0`` bind always has one), every route answers 401 without it and
its normal answer with it, the cookie of the first visit, the header forms, read-only mode,
the access log (the key in no log line) and the printed address.

Every request goes through the TestClient or to 127.0.0.1: an app "bound to 0.0.0.0" is built
as :func:`barkgen.web.serve` builds it for that host, and reached without any network."""

from __future__ import annotations

import json
import logging
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient
from starlette.routing import Mount
from test_web_api import _photo_png
from typer.testing import CliRunner

from barkgen.errors import InvalidInputError
from barkgen.io import encode_png
from barkgen.library import Library
from barkgen.web.app import allowed_hosts, build_server, create_app, served_address
from barkgen.web.middleware import ACCESS_LOG, READ_ONLY_REFUSAL, UNAUTHORIZED
from barkgen.web.state import WebAccess, is_loopback

KEY = "k3y-Of-The-Test_0123456789abcdef"
READING = ("GET", "HEAD", "OPTIONS")


@pytest.fixture()
def library(tmp_path):
    library = Library(tmp_path / "lib")
    exemplar = library.add_exemplar(_photo_png(), "oak")
    files = {"texture.png": encode_png(library.photo(exemplar.id)), "params.json": b"{}"}
    library.add_result(exemplar.id, {"size": "128x128"}, 1, files)
    return library


def _app(library, host: str, token: str | None = None, read_only: bool = False):
    """The app as :func:`barkgen.web.serve` builds it for ``host`` (jobs queued, not run)."""
    access = WebAccess(host, token=token, read_only=read_only)
    return create_app(library, run_jobs=False, hosts=allowed_hosts(host), access=access)


def _client(app) -> TestClient:
    # the Host a browser on this machine sends: 127.0.0.1 (the loopback app answers no other)
    return TestClient(app, base_url="http://127.0.0.1:8000", raise_server_exceptions=False)


def _flat(routes):
    """The routes, those of included routers too (this FastAPI keeps them in their router)."""
    for route in routes:
        included = getattr(route, "original_router", None)
        yield from _flat(included.routes) if included is not None else (route,)


def _every_request(library, job_id: str) -> list[tuple[str, str]]:
    """(method, path) of every route of the app, its parameters filled with real ids (a
    deleting route with an unknown one, so the walk changes nothing it reads later)."""
    exemplar, result = library.exemplars()[0].id, library.results()[0].id
    app = create_app(library, run_jobs=False)
    requests = []
    for route in _flat(app.routes):
        if isinstance(route, Mount):
            requests.append(("GET", f"{route.path}/app.css"))
            continue
        for method in sorted(route.methods or ()):
            if method == "HEAD" and "GET" in route.methods:
                continue
            deleting = method == "DELETE"
            values = {
                "exemplar_id": 999 if deleting else exemplar,
                "result_id": 999 if deleting else result,
                "job_id": "no-such-job" if deleting else job_id,
                "name": "texture.png",
            }
            path = route.path_format if isinstance(route, APIRoute) else route.path
            if path.endswith("/events"):  # a queued job's stream stays open: an unknown job's
                values["job_id"] = "no-such-job"
            requests.append((method, path.format(**values)))
    assert len(requests) >= 30, requests  # every page, API route, /openapi.json and a static file
    return requests


def _send(client, method: str, path: str, **kwargs):
    body = {} if method not in READING else None
    answer = client.request(method, path, json=body, follow_redirects=False, **kwargs)
    return answer.status_code, answer.content


@pytest.fixture()
def queued_job(library):
    with _client(create_app(library, run_jobs=False)) as client:
        answer = client.post(f"/api/exemplars/{library.exemplars()[0].id}/labels?k=2")
        assert answer.status_code == 200, answer.text
        return answer.json()["job"]["id"]


def test_the_bind_decides():
    assert all(is_loopback(host) for host in ("127.0.0.1", "127.8.9.1", "::1", "[::1]", "localhost"))
    assert not any(is_loopback(host) for host in ("0.0.0.0", "::", "192.168.1.5", "bark.local"))
    assert WebAccess("127.0.0.1").token is None and WebAccess("localhost").token is None
    assert WebAccess("127.0.0.1", token=KEY).token == KEY
    exposed = [WebAccess(host).token for host in ("0.0.0.0", "::", "192.168.1.5", "0.0.0.0")]
    assert all(token and len(token) >= 40 for token in exposed) and len(set(exposed)) == 4  # random
    assert WebAccess("0.0.0.0", token=KEY).token == KEY
    assert WebAccess("0.0.0.0", token="").token not in (None, "")  # an empty BARKGEN_TOKEN: none given
    for bad in ("short", "with space in the key!!", "ключ" * 8, "x" * 257):
        with pytest.raises(InvalidInputError, match="--token"):
            WebAccess("0.0.0.0", token=bad)
    assert KEY not in repr(WebAccess("0.0.0.0", token=KEY))


@pytest.mark.parametrize("host", ["127.0.0.1", "0.0.0.0"])
def test_every_route_needs_the_key(library, queued_job, host):
    """Without the key or with a wrong one: 401, one body for both, on every route; with it (each
    way of carrying it): the answer of the same app without a key."""
    requests = _every_request(library, queued_job)
    token = KEY if host == "127.0.0.1" else None  # on loopback a key only when given
    app = _app(library, host, token)
    token = app.state.barkgen.access.token
    assert token is not None
    with _client(app) as keyed, _client(_app(library, "127.0.0.1")) as open_app:
        refusals = set()
        for method, path in requests:
            for headers in ({}, {"X-Barkgen-Token": "wrong" + token}, {"Authorization": "Bearer " + token[:-1]}):
                status, body = _send(keyed, method, path, headers=headers)
                assert status == 401, (method, path, headers)
                refusals.add(body)
            status, body = _send(keyed, method, path + "?token=%E2%82%AC" + token)  # not even latin-1
            assert status == 401
            refusals.add(body)
            status, body = _send(keyed, method, path + "?token=" + token.upper())
            assert status == 401 and keyed.cookies.get("barkgen_token_8000") is None
            refusals.add(body)
        assert refusals == {json.dumps(UNAUTHORIZED, separators=(",", ":")).encode()}
        for number, (method, path) in enumerate(requests):
            way = ({"headers": {"Authorization": f"Bearer {token}"}}, {"headers": {"X-Barkgen-Token": token}})
            status = _send(keyed, method, path, **way[number % 2])[0]
            assert status == _send(open_app, method, path)[0] and status != 401, (method, path, status)
        assert [_send(keyed, *request)[0] for request in requests[:3]] == [401] * 3  # a header is no cookie


def test_loopback_without_a_key_is_open(library, queued_job):
    with _client(_app(library, "127.0.0.1")) as client:
        for method, path in _every_request(library, queued_job):
            assert _send(client, method, path)[0] != 401, (method, path)


def test_the_first_visit_leaves_a_cookie(library):
    app = _app(library, "0.0.0.0")
    token = app.state.barkgen.access.token
    with _client(app) as browser:
        assert browser.get("/").status_code == 401
        first = browser.get(f"/?token={token}", follow_redirects=False)
        # the key leaves the address bar: a redirect to the page, the key in a cookie
        assert first.status_code == 303 and first.headers["location"] == "/"
        cookie = first.headers["set-cookie"]
        assert cookie.startswith(f"barkgen_token_8000={token};")
        assert "HttpOnly" in cookie and "samesite=strict" in cookie.lower() and "Path=/" in cookie
        assert first.headers["cache-control"] == "no-store" and first.headers["referrer-policy"] == "no-referrer"
        # the page's own requests (fetch, <img>, EventSource, downloads) carry the cookie
        exemplar, result = library.exemplars()[0].id, library.results()[0].id
        for path in ("/", "/static/js/api.js", "/api/exemplars", f"/api/exemplars/{exemplar}/thumbnail.jpg"):
            assert browser.get(path).status_code == 200, path
        assert browser.get(f"/api/results/{result}/files/texture.png").status_code == 200
        assert browser.get("/api/server").json() == {"read_only": False}
        # another page's query keeps the rest of its address; a path of two slashes stays here
        answer = browser.get(f"/exemplars/{exemplar}?token={token}&job=j1", follow_redirects=False)
        assert answer.status_code == 303 and answer.headers["location"] == f"/exemplars/{exemplar}?job=j1"
        answer = browser.get(f"http://127.0.0.1:8000//elsewhere.example/?token={token}", follow_redirects=False)
        assert answer.headers["location"] == "/elsewhere.example/"
        browser.cookies.clear()
        # a wrong cookie is a wrong key; a script may pass the key in an API address (no redirect)
        browser.cookies.set("barkgen_token_8000", token + "x")
        assert browser.get("/").status_code == 401
        browser.cookies.clear()
        assert browser.get(f"/api/exemplars?token={token}", follow_redirects=False).status_code == 200
        assert "set-cookie" not in browser.get(f"/api/exemplars?token={token}").headers


def test_read_only_refuses_every_change(library, queued_job):
    requests = _every_request(library, queued_job)
    changing = [(method, path) for method, path in requests if method not in READING]
    photos = len(library.exemplars())
    assert {method for method, _ in changing} == {"POST", "DELETE"} and len(changing) >= 9
    with _client(_app(library, "127.0.0.1", read_only=True)) as viewer, _client(_app(library, "127.0.0.1")) as owner:
        assert viewer.get("/api/server").json() == {"read_only": True}
        for method, path in changing:
            answer = viewer.request(method, path, json={})
            assert answer.status_code == 403 and answer.json() == {"detail": READ_ONLY_REFUSAL}, (method, path)
        upload = viewer.post("/api/exemplars", files={"file": ("new.png", _photo_png(seed=5))})
        assert upload.status_code == 403 and len(library.exemplars()) == photos
        for method, path in requests:
            if method in READING:
                assert _send(viewer, method, path)[0] == _send(owner, method, path)[0] != 403, (method, path)
    # with a key: no key is 401 before anything is said of read-only
    app = _app(library, "0.0.0.0", read_only=True)
    with _client(app) as viewer:
        assert viewer.delete(f"/api/exemplars/{library.exemplars()[0].id}").status_code == 401
        key = {"X-Barkgen-Token": app.state.barkgen.access.token}
        assert viewer.delete(f"/api/exemplars/{library.exemplars()[0].id}", headers=key).status_code == 403
        assert viewer.get("/api/exemplars", headers=key).status_code == 200
    assert len(library.exemplars()) == photos and len(library.results()) == 1


def test_the_pages_hide_what_read_only_refuses():
    from barkgen.web.state import STATIC

    css = (STATIC / "app.css").read_text()
    assert ".read-only [data-changes] { display: none !important; }" in css
    assert '"/api/server"' in (STATIC / "js" / "api.js").read_text()
    assert 'class="panel upload" data-changes' in (STATIC / "index.html").read_text()
    exemplar, result = (STATIC / "exemplar.html").read_text(), (STATIC / "result.html").read_text()
    assert 'class="generate-bar" data-changes' in exemplar and 'class="crack-tools" data-changes' in exemplar
    assert 'class="relief-tools" data-changes' in result and 'class="panel painter" data-changes' in result


def test_an_access_line_per_change_and_the_key_in_none(library, caplog):
    caplog.set_level(logging.DEBUG)
    for client_side in ("httpx", "httpcore"):  # the test client's own log of what it sends
        logging.getLogger(client_side).setLevel(logging.WARNING)
    app = _app(library, "0.0.0.0", token=KEY)
    exemplar = library.exemplars()[0].id
    with _client(app) as client:
        client.get(f"/?token={KEY}")  # the cookie from here on
        job = client.post(f"/api/exemplars/{exemplar}/labels?k=4").json()["job"]["id"]
        upload = client.post("/api/exemplars", files={"file": ("new.png", _photo_png(seed=7))}).json()["id"]
        client.delete(f"/api/jobs/{job}")
        client.cookies.clear()
        client.get(f"/api/exemplars?token={KEY}")
        client.get(f"/{KEY}?token={KEY}x", headers={"Authorization": f"Bearer {KEY}y"})
        client.post(f"/api/jobs?token={KEY}", json={}, headers={"X-Barkgen-Token": KEY})
    lines = [record.getMessage() for record in caplog.records]
    assert lines and not [line for line in lines if KEY in line]
    assert KEY not in caplog.text
    access = [r for r in caplog.records if r.name == "barkgen.web.middleware"]
    said = [r.getMessage() for r in access]
    assert f"testclient POST /api/exemplars/{exemplar}/labels 200 exemplar={exemplar} job={job}" in said
    assert f"testclient POST /api/exemplars 201 exemplar={upload}" in said
    assert f"testclient DELETE /api/jobs/{job} 200 job={job}" in said
    assert "testclient GET /[key] refused: no valid key" in said
    assert "testclient POST /api/jobs 422" in said
    assert all(r.created > time.time() - 120 for r in access)  # when: the record's time, printed by serve


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_real_server_logs_no_key(library, capfd):
    """uvicorn on 127.0.0.1 with a key: its logs and barkgen's access lines (stderr) hold no key,
    and the printed address opens the library."""
    printed = []
    port = _free_port()
    server = build_server(library, "127.0.0.1", port, access=WebAccess("127.0.0.1", token=KEY), on_ready=printed.append)
    server.config.app.state.barkgen.jobs.eager = False
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + 30
        while not printed:
            assert time.monotonic() < deadline and thread.is_alive()
            time.sleep(0.05)
        assert printed == [f"http://127.0.0.1:{port}/?token={KEY}"]
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/exemplars?token={KEY}", timeout=10) as answer:
            assert answer.status == 200
        for token in ("", KEY + "x"):
            request = urllib.request.Request(f"http://127.0.0.1:{port}/api/jobs/x?token={token}", method="DELETE")
            with pytest.raises(urllib.error.HTTPError) as refused:
                urllib.request.urlopen(request, timeout=10)
            assert refused.value.code == 401
    finally:
        server.should_exit = True
        thread.join(20)
        for handler in ACCESS_LOG.handlers[:]:  # it writes to this test's captured stderr
            ACCESS_LOG.removeHandler(handler)
        ACCESS_LOG.setLevel(logging.NOTSET)
    logged = capfd.readouterr()
    assert "refused: no valid key" in logged.err and KEY not in logged.err + logged.out


def test_the_printed_address():
    assert served_address("127.0.0.1", 8000) == "http://127.0.0.1:8000/"
    assert served_address("0.0.0.0", 8000, KEY) == f"http://127.0.0.1:8000/?token={KEY}"
    assert served_address("::1", 8001, KEY) == f"http://[::1]:8001/?token={KEY}"
    assert served_address("192.168.1.5", 80, KEY) == f"http://192.168.1.5:80/?token={KEY}"


@pytest.mark.parametrize(
    ("argv", "env", "keyed"),
    [
        (["--host", "0.0.0.0"], {}, "random"),
        (["--host", "0.0.0.0", "--token", KEY], {}, KEY),
        (["--host", "0.0.0.0"], {"BARKGEN_TOKEN": KEY}, KEY),
        (["--host", "127.0.0.1"], {}, None),
        (["--host", "127.0.0.1"], {"BARKGEN_TOKEN": KEY}, KEY),
    ],
)
def test_serve_prints_the_key(tmp_path, monkeypatch, argv, env, keyed):
    """``barkgen serve``'s address, without binding anything: the server is replaced by one
    that says it listens and stops."""
    import barkgen.cli.serve as serve_cli
    import barkgen.web
    from barkgen.cli.app import app

    given = {}

    def fake_serve(library, host, port, *, limits, access, on_ready):
        given["access"] = access
        on_ready(served_address(host, port, access.token))

    monkeypatch.setattr(barkgen.web, "serve", fake_serve)
    monkeypatch.setattr(serve_cli, "_check_port_free", lambda host, port: None)
    monkeypatch.delenv("BARKGEN_TOKEN", raising=False)
    result = CliRunner().invoke(app, ["serve", *argv, "--library", str(tmp_path / "lib")], env=env)
    assert result.exit_code == 0, result.output
    token = given["access"].token
    if keyed is None:
        assert token is None and "running at http://127.0.0.1:8000/  (" in result.output
    else:
        assert token == keyed if keyed != "random" else len(token) >= 40
        assert f"running at http://127.0.0.1:8000/?token={token}  (" in result.output
    assert ("in clear (no TLS)" in result.output) == ("0.0.0.0" in argv)
    other = f"from another machine: http://{socket.gethostname()}:8000/?token={token}\n"
    assert (other in result.output) == ("0.0.0.0" in argv)
    refused = CliRunner().invoke(app, ["serve", *argv, "--token", "short"], env=env)
    assert refused.exit_code == 2 and "--token (or BARKGEN_TOKEN) must be 16-256" in refused.output


def _start(tmp_path, port: int, *flags: str):
    """``barkgen serve`` on 127.0.0.1 with ``flags``, as a user starts it; its process and log."""
    import subprocess
    import sys

    log = open(tmp_path / f"serve{port}.log", "w+")
    argv = [sys.executable, "-m", "barkgen", "serve", "--port", str(port), "--library", str(tmp_path / "lib"), *flags]
    process = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while "barkgen is running at" not in (tmp_path / f"serve{port}.log").read_text():
        assert process.poll() is None and time.monotonic() < deadline, (tmp_path / f"serve{port}.log").read_text()
        time.sleep(0.2)
    return process, log


@pytest.mark.parametrize("read_only", [False, True])
def test_a_browser_opens_the_printed_address(tmp_path, read_only):
    """Chromium on the printed address (127.0.0.1, a key given): the key leaves the address bar,
    the page's fetches and images carry the cookie (the library, a thumbnail, a label map made by
    a job); read-only, the upload form and Generate are hidden. Without the key: 401."""
    from test_web_browser import CHROMIUM, CHROMIUM_ARGS

    if not CHROMIUM.exists():
        pytest.skip("needs Debian's chromium at /usr/bin/chromium")
    from playwright.sync_api import sync_playwright

    port = _free_port()
    process, log = _start(tmp_path, port, "--token", KEY, *(["--read-only"] if read_only else []))
    base = f"http://127.0.0.1:{port}"
    try:
        with sync_playwright() as playwright:
            chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            page = chromium.new_page()
            assert page.goto(f"{base}/").status == 401
            assert page.goto(f"{base}/?token={KEY}").status == 200 and page.url == f"{base}/"
            card = page.get_by_test_id("exemplar-card").first
            card.wait_for(timeout=20000)
            page.wait_for_function(
                "() => [...document.querySelectorAll('.card img')].some(i => i.complete && i.naturalWidth > 0)",
                timeout=20000,
            )
            assert page.locator("section.upload").is_visible() is not read_only
            card.click()
            page.wait_for_url(f"{base}/exemplars/**")
            page.wait_for_selector("html.read-only" if read_only else "[data-testid=generate]", state="attached")
            assert page.get_by_test_id("generate").is_visible() is not read_only
            if not read_only:  # a label job, followed by polling, then its picture: all with the cookie
                page.wait_for_function(
                    "() => { const i = document.querySelector('[data-testid=labels-in]');"
                    " return i.complete && i.naturalWidth > 0; }",
                    timeout=120000,
                )
            cookies = page.context.cookies()
            assert [(c["name"], c["httpOnly"], c["sameSite"]) for c in cookies] == [
                (f"barkgen_token_{port}", True, "Strict")
            ]
            chromium.close()
    finally:
        process.terminate()
        process.wait(timeout=30)
        log.close()
    assert KEY not in (tmp_path / f"serve{port}.log").read_text().replace(f"?token={KEY}", "", 1)
