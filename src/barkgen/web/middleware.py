"""The web app's ASGI middleware: a bound on request bodies (:class:`BodyLimit`) and the checks
against cross-site requests and DNS rebinding (:class:`SameOrigin`)."""

from __future__ import annotations

from fastapi import HTTPException
from fastapi.responses import JSONResponse


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
    be one of ``hosts`` (when given), and a request that changes anything (not GET/HEAD) from
    a browser must come from the app's own origin."""

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
        if scope["method"] not in ("GET", "HEAD") and origin is not None:
            if origin.decode("latin-1").split("://", 1)[-1] != host:
                return await JSONResponse({"detail": "cross-site requests are not allowed"},
                                          status_code=403)(scope, receive, send)
        return await self.app(scope, receive, send)
