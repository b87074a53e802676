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
