"""The web app's ASGI middleware: the key, read-only mode and the access log
(:class:`AccessKey`), a bound on request bodies (:class:`BodyLimit`) and the checks against
cross-site requests and DNS rebinding (:class:`SameOrigin`)."""

from __future__ import annotations

import hmac
import json
import logging
import re
from urllib.parse import parse_qsl, urlencode

from fastapi import HTTPException
from fastapi.responses import JSONResponse, RedirectResponse

from barkgen.web.state import WebAccess

#: who did what, when: one line per change (upload, job, delete, paint, relief) and per refused key
ACCESS_LOG = logging.getLogger(__name__)  # barkgen.web.middleware: the access lines
#: the methods that change nothing (read-only mode lets them through)
READING_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
#: the one answer to a missing or wrong key: the same for both, with no hint
UNAUTHORIZED = {"detail": "Unauthorized"}
READ_ONLY_REFUSAL = "this server is read-only: nothing can be changed"
_ID_IN_PATH = re.compile(r"^/api/(exemplars|jobs|results)/([^/]+)")
_LOGGED_BODY = 64 * 1024  # a change's answer is read for the id it made up to this size


def _printable(text: str) -> str:
    """``text`` fit for one log line (an address may hold a decoded newline)."""
    return "".join(c if c.isprintable() else "?" for c in text)[:300]


class AccessKey:
    """ASGI middleware: the key (``access.token``: every request must carry it, as
    ``Authorization: Bearer KEY``, an ``X-Barkgen-Token`` header, the cookie this middleware
    sets, or ``?token=KEY``, compared in constant time), read-only mode (every
    POST/PUT/PATCH/DELETE refused, 403) and the access log (a line on this module's logger
    per change: client address, method, path, status, the id it touched or made; never the
    key, never the query).

    A page visited with a right ``?token=`` is redirected to its address without it, with the
    key in a cookie (HttpOnly, SameSite=Strict), which the page's own requests then carry.
    """

    def __init__(self, app, access: WebAccess) -> None:
        self.app, self.read_only = app, access.read_only
        self.key = None if access.token is None else access.token.encode()

    def _matches(self, presented: bytes | None) -> bool:
        return presented is not None and hmac.compare_digest(presented, self.key or b"")

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        method = scope["method"]
        if self.key is not None:
            cookie_name = f"barkgen_token_{(scope.get('server') or ('', 0))[1]}".encode()
            query = parse_qsl(scope.get("query_string", b"").decode("latin-1"), keep_blank_values=True)
            by_query = next((value.encode("utf-8", "replace") for name, value in query if name == "token"), None)
            presented = _presented_keys(scope["headers"], cookie_name)
            matched = False
            for candidate in (*presented, by_query):  # each compared: no early way out to time
                matched |= self._matches(candidate)
            if not matched:
                _log(scope, "refused: no valid key", key=self.key)
                return await JSONResponse(UNAUTHORIZED, 401, {"WWW-Authenticate": "Bearer"})(scope, receive, send)
            if self._matches(by_query) and method in ("GET", "HEAD") and not scope["path"].startswith("/api/"):
                # the first visit of a page: the key moves from the address bar to a cookie
                rest = urlencode([(name, value) for name, value in query if name != "token"])
                target = "/" + scope["path"].lstrip("/") + (f"?{rest}" if rest else "")
                redirect = RedirectResponse(
                    target, 303, {"Cache-Control": "no-store", "Referrer-Policy": "no-referrer"}
                )
                redirect.set_cookie(cookie_name.decode(), self.key.decode(), httponly=True, samesite="strict", path="/")
                return await redirect(scope, receive, send)
        if method in READING_METHODS:
            return await self.app(scope, receive, send)
        if self.read_only:
            _log(scope, "refused: read-only", key=self.key)
            return await JSONResponse({"detail": READ_ONLY_REFUSAL}, 403)(scope, receive, send)
        answer = {"status": 500, "body": b"", "json": False}

        async def noting_send(message):
            if message["type"] == "http.response.start":
                answer["status"] = message["status"]
                answer["json"] = (
                    dict(message.get("headers", [])).get(b"content-type", b"").startswith(b"application/json")
                )
            elif message["type"] == "http.response.body" and answer["json"] and len(answer["body"]) < _LOGGED_BODY:
                answer["body"] += message.get("body", b"")
            await send(message)

        try:
            await self.app(scope, receive, noting_send)
        finally:
            _log(scope, str(answer["status"]), _made_id(scope["path"], answer["body"]), self.key)


def _presented_keys(headers, cookie_name: bytes) -> list[bytes]:
    """The keys a request carries in its headers: bearer, ``X-Barkgen-Token``, the cookie."""
    keys = []
    for name, value in headers:
        if name == b"authorization" and value[:7].lower() == b"bearer ":
            keys.append(value[7:].strip())
        elif name == b"x-barkgen-token":
            keys.append(value.strip())
        elif name == b"cookie":
            for pair in value.split(b";"):
                key, _, cookie = pair.strip().partition(b"=")
                if key == cookie_name:
                    keys.append(cookie.strip(b'"'))
    return keys


def _made_id(path: str, body: bytes) -> str:
    """The id a change's JSON answer names (an upload's exemplar, a new job), if any."""
    try:
        answer = json.loads(body) if body else None
    except ValueError:
        return ""
    if not isinstance(answer, dict):
        return ""
    job = answer.get("job")
    if isinstance(job, dict) and "id" in job:
        return f"job={_printable(str(job['id']))}"
    if "id" in answer:
        kind = "job" if path.startswith("/api/jobs") else "exemplar" if path.startswith("/api/exemplars") else "id"
        return f"{kind}={_printable(str(answer['id']))}"
    return ""


def _log(scope, outcome: str, made: str = "", key: bytes | None = None) -> None:
    """One access line: who (client address), what (method, path, the ids), the outcome; the
    time is the record's. The query (which may hold the key) is never written."""
    client = (scope.get("client") or ("-", 0))[0]
    path = scope["path"]
    touched = _ID_IN_PATH.match(path)
    ids = " ".join(dict.fromkeys(part for part in (f"{touched[1][:-1]}={touched[2]}" if touched else "", made) if part))
    line = f"{client} {scope['method']} {_printable(path)} {outcome}" + (f" {_printable(ids)}" if ids else "")
    if key:  # a key typed into the path by mistake is not written either
        line = line.replace(key.decode(), "[key]")
    ACCESS_LOG.info("%s", line)


class BodyTooLarge(HTTPException):
    """A request body over the limit (raised while it arrives, answered 413)."""


class BodyLimit:
    """ASGI middleware: a request body may hold at most ``limit`` bytes, whether its length is
    declared (refused before it is read) or not (chunked: refused as soon as it goes over), so
    no upload fills memory or disk past the limit."""

    def __init__(self, app, limit: int, detail: str) -> None:
        self.app, self.limit, self.detail = app, limit, detail

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = dict(scope["headers"]).get(b"content-length", b"")
        if length.isdigit() and int(length) > self.limit:
            return await JSONResponse({"detail": self.detail}, status_code=413)(scope, receive, send)
        received = 0

        async def limited():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.limit:
                    raise BodyTooLarge(413, self.detail)
            return message

        return await self.app(scope, limited, send)


class SameOrigin:
    """ASGI middleware against cross-site requests and DNS rebinding: the ``Host`` header must
    be one of ``hosts`` (when given), a request with an ``Origin`` must come from the app's own
    (any method: a GET reads the library's photos and results), and a GET of
    ``/api/`` that the browser says comes from another site or port (``Sec-Fetch-Site``, sent
    for an ``<img>`` too, which sends no Origin) is refused. The pages themselves may be linked
    from anywhere."""

    def __init__(self, app, hosts: list[str] | None) -> None:
        self.app, self.hosts = app, hosts

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = dict(scope["headers"])
        host = headers.get(b"host", b"").decode("latin-1")
        name = host.rsplit(":", 1)[0] if not host.endswith("]") else host
        if self.hosts is not None and name.strip("[]") not in self.hosts:
            return await JSONResponse({"detail": f"unknown host {host!r}"}, status_code=400)(scope, receive, send)
        origin = headers.get(b"origin")
        foreign = origin is not None and origin.decode("latin-1").split("://", 1)[-1] != host
        # a GET of the API from another page (an <img> or fetch of another site, or of another
        # port of this machine) sends no Origin for images, but browsers say where it comes
        # from: only the app's own pages and typed addresses may read the API
        fetched_from = headers.get(b"sec-fetch-site", b"").decode("latin-1")
        from_elsewhere = fetched_from in ("cross-site", "same-site") and scope["path"].startswith("/api/")
        if foreign or from_elsewhere:
            return await JSONResponse({"detail": "cross-site requests are not allowed"}, status_code=403)(
                scope, receive, send
            )
        return await self.app(scope, receive, send)
