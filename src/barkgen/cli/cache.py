"""``barkgen cache``: the photo analysis cache that ``generate``, ``batch`` and the web app share
(:class:`barkgen.pipeline.AnalysisStore`): where it is, what it holds, and clearing it."""

from __future__ import annotations

import time

import typer

#: help of the ``cache`` group
HELP = (
    "The photo analysis cache: a photo's analysis is kept on disk so that another seed of the same photo "
    "and options skips it ($BARKGEN_CACHE_DIR, default in your user cache folder; $BARKGEN_CACHE_MAX "
    "bounds it, default 2G; --no-cache or $BARKGEN_NO_CACHE=1 leave it out)."
)


def _megabytes(size: int) -> str:
    return f"{size / 1e6:.1f} MB"


def show_command() -> None:
    """Print the cache's folder, bound, entries and total size, then one line per entry (least
    recently used first): when it was last used, its size, the photo's size and its options."""
    from barkgen.pipeline import AnalysisStore

    store = AnalysisStore()
    entries = store.entries()
    total = sum(e.size for e in entries)
    typer.echo(f"folder: {store.folder}")
    typer.echo(f"limit: {_megabytes(store.max_bytes)}")
    typer.echo(f"entries: {len(entries)}, {_megabytes(total)}")
    for entry in entries:
        about = entry.description
        options = about.get("options", {})
        what = ", ".join(f"{k}={v}" for k, v in options.items() if k in ("size", "k", "method", "material"))
        used = time.strftime("%Y-%m-%d %H:%M", time.localtime(entry.last_used))
        typer.echo(f"{entry.key[:12]}  {used}  {_megabytes(entry.size):>10}  photo {about.get('photo', '?')}  {what}")


def clear_command() -> None:
    """Remove every entry of the cache (the next run of each photo analyses it again)."""
    from barkgen.pipeline import AnalysisStore

    store = AnalysisStore()
    count, size = store.clear()
    typer.echo(f"removed {count} entries ({_megabytes(size)}) from {store.folder}")


#: (command name, function) of this group
COMMANDS = (("show", show_command), ("clear", clear_command))
