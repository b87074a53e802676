"""``barkgen serve``: the web app (:func:`barkgen.web.serve`) on the exemplar library."""

from __future__ import annotations

from typing import Annotated

import typer

from barkgen.cli._common import LibraryOption, NoCacheOption
from barkgen.errors import InvalidInputError


def serve_command(
    host: Annotated[
        str,
        typer.Option(
            "--host",
            help="Address to listen on (127.0.0.1: this machine only; any other, 0.0.0.0 above all: every "
            "machine that reaches the port, which then needs the key printed in the address; no TLS: "
            "beyond a trusted network, use an SSH tunnel or a reverse proxy with TLS).",
        ),
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", help="Port to listen on.")] = 8000,
    token: Annotated[
        str | None,
        typer.Option(
            "--token",
            envvar="BARKGEN_TOKEN",
            show_envvar=True,
            help="The key every request must carry (16-256 URL-safe characters). Beyond 127.0.0.1 a "
            "random one is made when none is given; on 127.0.0.1 none is asked unless given.",
        ),
    ] = None,
    read_only: Annotated[
        bool,
        typer.Option(
            "--read-only", help="Refuse every change (uploads, jobs, deletes, paints): a library shared to viewers."
        ),
    ] = False,
    library: LibraryOption = None,
    max_upload_mb: Annotated[int, typer.Option("--max-upload-mb", help="Largest upload in MB.")] = 25,
    max_upload_mp: Annotated[float, typer.Option("--max-upload-mp", help="Largest upload in megapixels.")] = 50,
    no_cache: NoCacheOption = False,
) -> None:
    """Run the web app: pick or upload bark, generate with one click, paint labels, see it on a
    trunk, download the material set. Open the printed address; beyond 127.0.0.1 it holds the
    key every request needs (docs: "Who can reach it")."""
    import math

    from barkgen._shared.extras import require_extra

    require_extra("web", "the web app (barkgen serve)")  # first: what to install, whatever the flags
    # neither serve() nor WebLimits checks these: uvicorn would fail with a traceback (and
    # before the web app's imports: a refusal in a fraction of a second)
    if not 0 < port < 65536:
        raise InvalidInputError(f"--port must be 1-65535, not {port}")
    for flag, value in (("--max-upload-mb", max_upload_mb), ("--max-upload-mp", max_upload_mp)):
        if not math.isfinite(value) or not 0 < value <= 1e6:
            raise InvalidInputError(f"{flag} must be a number above 0 (and at most 1000000), not {value}")
    from barkgen.library import Library
    from barkgen.web import WebLimits, serve
    from barkgen.web.state import WebAccess

    access = WebAccess(host, token=token, read_only=read_only)  # the bind decides whether a key is asked
    lib = Library(library)
    _check_port_free(host, port)
    if no_cache:  # read by the job worker, a process of its own (barkgen.pipeline.open_store)
        import os

        from barkgen.pipeline.analysis_cache import ENV_OFF

        os.environ[ENV_OFF] = "1"
    limits = WebLimits(max_upload_bytes=max_upload_mb * 1024**2, max_upload_pixels=int(max_upload_mp * 1e6))

    from barkgen.web.app import served_address
    from barkgen.web.assets import missing_warning
    from barkgen.web.state import is_loopback

    def ready(url: str) -> None:
        typer.echo(f"barkgen is running at {url}  (library: {lib.path}; Ctrl-C stops it)", err=True)
        if (missing := missing_warning()) is not None:
            typer.echo(missing, err=True)
        if not is_loopback(host):
            if host in ("0.0.0.0", "::", ""):  # the address to give the other machines (no look-up)
                import socket

                other = served_address(socket.gethostname(), port, access.token)
                typer.echo(f"from another machine: {other}", err=True)
            typer.echo(
                f"barkgen: warning: listening on {host}: whoever has the address with its key can use this "
                "server and its library; the key and the photos cross the network in clear (no TLS)",
                err=True,
            )
        if read_only:
            typer.echo("barkgen: read-only: uploads, jobs, deletes and edits are refused", err=True)

    try:
        serve(lib, host=host, port=port, limits=limits, access=access, on_ready=ready)
    except KeyboardInterrupt:  # Ctrl-C is how a server is stopped: not an error
        pass
    typer.echo("barkgen: server stopped", err=True)


def _check_port_free(host: str, port: int) -> None:
    """A clear line instead of uvicorn's traceback when the port is taken."""
    import socket

    try:
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
    except OSError as exc:
        raise InvalidInputError(f"cannot listen on {host}:{port} ({exc.strerror or exc}); try another --port") from None


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (("serve", serve_command),)
