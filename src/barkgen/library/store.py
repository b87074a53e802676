"""Content-addressed files of the exemplar library: each file is stored once, under the SHA-256
of its bytes, in ``objects/ab/cdef...`` of the library folder, and written atomically (a
temporary file renamed into place), so a killed process never leaves a half-written object
under a real name."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path


def _is_digest(text: str) -> bool:
    return len(text) == 64 and all(c in "0123456789abcdef" for c in text)


def set_digest(maps: Mapping[str, bytes]) -> str:
    """A scanned set's identity in the library (its entry's ``image_hash``): the SHA-256 of
    its file names and their contents' hashes, so the same set is one entry and a set is
    never taken for a photo of its colour."""
    listing = json.dumps({name: content_hash(data) for name, data in sorted(maps.items())}, sort_keys=True)
    return content_hash(b"barkgen scanned set\n" + listing.encode())


def content_hash(data: bytes) -> str:
    """The SHA-256 hex digest that names ``data`` in the store."""
    return hashlib.sha256(data).hexdigest()


class ObjectStore:
    """Files by content hash under ``root``."""

    def __init__(self, root: str | os.PathLike) -> None:
        self.root = Path(root)

    def path(self, digest: str) -> Path:
        if not _is_digest(digest):
            raise ValueError(f"not a content hash: {digest!r}")
        return self.root / digest[:2] / digest[2:]

    def put(self, data: bytes) -> str:
        """Store ``data`` (once) and return its hash."""
        digest = content_hash(data)
        target = self.path(digest)
        if target.exists():
            return digest
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return digest

    def get(self, digest: str) -> bytes:
        return self.path(digest).read_bytes()

    def exists(self, digest: str) -> bool:
        return self.path(digest).exists()

    def remove(self, digest: str) -> None:
        self.path(digest).unlink(missing_ok=True)

    def digests(self) -> set[str]:
        """Every stored hash: only files named as objects are (temporary files left by a killed
        writer, a desktop's ``.DS_Store`` or ``Thumbs.db`` are not)."""
        if not self.root.is_dir():
            return set()
        return {
            sub.name + path.name
            for sub in self.root.iterdir()
            if sub.is_dir()
            for path in sub.iterdir()
            if _is_digest(sub.name + path.name)
        }

    def remove_unused(self, used: set[str]) -> int:
        """Remove every stored file whose digest is not in ``used``; returns how many."""
        unused = self.digests() - used
        for digest in unused:
            self.remove(digest)
        return len(unused)


def default_library_path() -> Path:
    """The default library folder: ``$BARKGEN_LIBRARY``, else ``barkgen/library`` in the user's data
    directory (``~/.local/share/barkgen/library`` on Linux).

    Returns
    -------
    Path
    """
    env = os.environ.get("BARKGEN_LIBRARY")
    if env:
        return Path(env).expanduser()
    import platformdirs

    return platformdirs.user_data_path("barkgen") / "library"
