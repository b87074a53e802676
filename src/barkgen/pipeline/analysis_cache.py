"""The photo's analysis once per photo: a content-addressed cache of
:class:`~barkgen.pipeline.PhotoAnalysis` on disk, shared by ``barkgen generate``, ``barkgen
batch`` and the web app (laitoch2018 Figure 1.2's per-photo steps; mazzolini2012 §4.1.2:
analysis once, synthesis many times).

An entry's key is the SHA-256 of everything the analysis depends on: the photo's decoded pixels
(dtype, shape, bytes), the options marked ``analysis=True`` (:func:`~barkgen.pipeline.analysis_key`),
the extra maps, the user's label map, a scanned set's maps and an edited crack network, and
:func:`cache_version` (barkgen's version and the digest of its code, this file format, and the
versions of the libraries whose numbers the analysis holds), so that an upgrade, or an edit of
barkgen's code, is a miss. Same seed, same bytes, from a hit or without the cache.

One file per entry (``<key>.analysis``): a header (magic, :data:`CACHE_FORMAT`, the payload's
length and CRC-32, a short JSON description) then the pickle (protocol 5) and its arrays'
buffers, each 64-byte aligned, read back with one read and unpickled without a copy. Written to a
unique temporary file in the same folder, flushed to disk, then renamed into place: two
processes writing one key at once each rename a whole file, and a reader sees an old whole file
or a new one. A file that fails its checks (torn, truncated, of another format) is a miss and is
removed. The folder is bounded (:data:`DEFAULT_MAX_BYTES`, ``$BARKGEN_CACHE_MAX``); the least
recently used entries go first (a hit touches its file).

The folder: ``$BARKGEN_CACHE_DIR``, else ``analysis`` in the user cache folder (platformdirs);
``$BARKGEN_NO_CACHE=1`` turns the cache off for every front end. The folder is the user's own
(mode 0700): an entry is unpickled, so nobody else may write there.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import pickle
import struct
import tempfile
import threading
import time
import zlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.pipeline.options import GenerateOptions, analysis_key

if TYPE_CHECKING:
    from barkgen._shared.arrays import ProgressCallback
    from barkgen.pipeline.core import PhotoAnalysis

__all__ = [
    "CACHE_FORMAT",
    "DEFAULT_MAX_BYTES",
    "AnalysisStore",
    "CacheEntry",
    "analysis_digest",
    "cache_folder",
    "cache_version",
    "cached_analysis",
    "open_store",
]

#: the layout of an entry's file; a change of it (or of what a key covers) is a new number
CACHE_FORMAT = 1
#: the cache's default bound (about ten analyses of 1024² photos)
DEFAULT_MAX_BYTES = 2 * 2**30
#: the environment: the folder, its bound (e.g. ``2G``), and the cache off (``1``)
ENV_FOLDER, ENV_MAX, ENV_OFF = "BARKGEN_CACHE_DIR", "BARKGEN_CACHE_MAX", "BARKGEN_NO_CACHE"

_MAGIC = b"BKGANLYS"
#: magic, format, buffers, description length, payload length, payload CRC-32
_HEADER = struct.Struct("<8sIIIQI")
_ALIGN = 64
_SUFFIX = ".analysis"
_TEMP_PREFIX = ".tmp-"
#: a temporary file older than this is a writer's that died: removed when the cache is evicted
_STALE_TEMP_S = 3600.0
#: the libraries whose numbers an analysis holds (k-means, PCA, faiss indexes, numba kernels)
_LIBRARIES = (
    "numpy",
    "numba",
    "scipy",
    "scikit-learn",
    "scikit-image",
    "faiss-cpu",
    "opencv-python-headless",
    "opencv-python",
)


@functools.cache
def cache_version() -> tuple:
    """What an entry is valid for: barkgen's version and a digest of its code (an edited source
    checkout is a new version too), :data:`CACHE_FORMAT`, Python's and the numeric libraries'
    versions. Part of every key."""
    from importlib import metadata

    from barkgen._version import __version__

    root = Path(__file__).resolve().parents[1]
    code = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        code.update(str(path.relative_to(root)).encode() + b"\0")
        code.update(path.read_bytes())
    libraries = []
    for name in _LIBRARIES:
        try:
            libraries.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            continue
    python = ".".join(map(str, __import__("sys").version_info[:2]))
    return (__version__, code.hexdigest()[:16], CACHE_FORMAT, python, tuple(libraries))


def _feed(digest: Any, value: Any) -> None:
    """Add ``value`` to ``digest`` unambiguously: arrays by dtype, shape and bytes, mappings by
    sorted key, dataclasses field by field, objects with ``to_dict`` (a crack network) by it."""
    if value is None or isinstance(value, (bool, int, float, str, bytes)):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
    elif isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        digest.update(f"ndarray:{array.dtype.str}:{array.shape};".encode())
        digest.update(array.reshape(-1).view(np.uint8).data)
    elif isinstance(value, np.generic):
        _feed(digest, value.item())
    elif isinstance(value, Mapping):
        digest.update(f"map:{len(value)};".encode())
        for key in sorted(value, key=str):
            _feed(digest, str(key))
            _feed(digest, value[key])
    elif isinstance(value, (tuple, list)):
        digest.update(f"seq:{len(value)};".encode())
        for item in value:
            _feed(digest, item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        digest.update(f"{type(value).__qualname__}{{".encode())
        for f in dataclasses.fields(value):
            _feed(digest, f.name)
            _feed(digest, getattr(value, f.name))
        digest.update(b"}")
    elif hasattr(value, "to_dict"):
        digest.update(f"{type(value).__qualname__}:".encode())
        digest.update(json.dumps(value.to_dict(), sort_keys=True, default=str).encode())
    else:
        raise TypeError(f"the analysis cache cannot key a {type(value).__name__}")


def analysis_digest(
    photo: np.ndarray,
    options: GenerateOptions,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    scan: Any = None,
    cracks: Any = None,
    solvers: bool = True,
) -> str:
    """The cache key of ``analyze_photo(photo, options, ...)``: SHA-256 (hex) of the photo's
    pixels, :func:`~barkgen.pipeline.analysis_key` of ``options``, the other inputs and
    :func:`cache_version`. The seed, size aside, plays no part."""
    digest = hashlib.sha256()
    _feed(digest, cache_version())
    _feed(digest, np.asarray(photo))
    _feed(digest, analysis_key(options))
    _feed(digest, dict(extra or {}))
    _feed(digest, None if labels_in is None else np.asarray(labels_in))
    _feed(digest, scan)
    _feed(digest, cracks)
    _feed(digest, bool(solvers))
    return digest.hexdigest()


def cache_folder() -> Path:
    """``$BARKGEN_CACHE_DIR``, else ``analysis`` in the user cache folder (platformdirs)."""
    env = os.environ.get(ENV_FOLDER)
    if env:
        return Path(env).expanduser()
    import platformdirs

    return platformdirs.user_cache_path("barkgen") / "analysis"


def _max_bytes_from_env() -> int:
    from barkgen._shared.memory import parse_memory

    text = os.environ.get(ENV_MAX)
    return DEFAULT_MAX_BYTES if not text else int(parse_memory(text) or DEFAULT_MAX_BYTES)


def _padding(n: int) -> int:
    return -n % _ALIGN


@dataclass(frozen=True)
class CacheEntry:
    """One entry of the cache: its key, file, size in bytes, when it was last used (seconds
    since the epoch) and what it is (the photo's size and the options, from its header)."""

    key: str
    path: Path
    size: int
    last_used: float
    description: dict


class AnalysisStore:
    """The analyses on disk (the module's docstring says how).

    Parameters
    ----------
    folder : path, optional
        Where the entries are (default :func:`cache_folder`); made on the first write.
    max_bytes : int, optional
        The bound of the folder's entries (default ``$BARKGEN_CACHE_MAX``, else
        :data:`DEFAULT_MAX_BYTES`): after a write the least recently used go.
    """

    def __init__(self, folder: str | Path | None = None, max_bytes: int | None = None) -> None:
        self.folder = Path(folder).expanduser() if folder is not None else cache_folder()
        self._writers: list[threading.Thread] = []
        self.max_bytes = int(max_bytes) if max_bytes is not None else _max_bytes_from_env()
        if self.max_bytes <= 0:
            raise InvalidInputError(f"the analysis cache's bound must be above 0 bytes, not {self.max_bytes}")

    def path(self, key: str) -> Path:
        return self.folder / f"{key}{_SUFFIX}"

    # ---------------------------------------------------------------- reading

    def get(self, key: str) -> PhotoAnalysis | None:
        """The analysis stored under ``key`` (its file touched: recently used), or None: absent,
        or a file that fails its checks (removed)."""
        path = self.path(key)
        try:
            with open(path, "rb") as handle:
                inode = os.fstat(handle.fileno()).st_ino
                data = _read_whole(handle)
        except (OSError, ValueError):
            return None
        analysis = _decode(data) if data is not None else None
        if analysis is None:
            self._remove_if(path, inode)
            return None
        try:
            os.utime(path)
        except OSError:
            pass
        return analysis

    def _remove_if(self, path: Path, inode: int) -> None:
        """Remove a bad entry unless another writer has just replaced it with a new file."""
        try:
            if os.stat(path).st_ino == inode:
                path.unlink()
        except OSError:
            pass

    # ---------------------------------------------------------------- writing

    def put(self, key: str, analysis: PhotoAnalysis, description: dict | None = None, *, wait: bool = True) -> bool:
        """Store ``analysis`` under ``key`` (atomically: a unique temporary file, flushed to
        disk, renamed into place), then evict the least recently used entries beyond
        ``max_bytes``. False when it was not stored: larger than the bound, or the folder not
        writable (the cache never fails a run).

        With ``wait=False`` the analysis is pickled now (its arrays are not copied: the caller
        leaves them as they are, as :func:`~barkgen.pipeline.generate` does) and written on a
        thread of its own while the run goes on (the 1024² quickstart's 230 MB: 0.9 s, mostly
        the disk's); :meth:`flush` waits for it. Returns True then."""
        parts = _encode(analysis, description or {})
        if _HEADER.size + sum(_length(p) for p in parts) > self.max_bytes:
            return False
        if wait:
            return self._write(key, parts)
        writer = threading.Thread(target=self._write_behind, args=(key, parts), name="barkgen-cache-write")
        writer.start()
        self._writers.append(writer)
        return True

    def flush(self) -> None:
        """Wait for the writes that :meth:`put` left to a thread."""
        while self._writers:
            self._writers.pop().join()

    def _write_behind(self, key: str, parts: list) -> None:
        """:meth:`_write` on its own thread, at the lowest priority (Linux: a thread's own nice
        value): it takes what the run leaves of the cores instead of slowing the run (the
        quickstart's new photo: 0.3 s of its 9.4 s at the run's priority)."""
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)
        except (AttributeError, OSError):  # not Linux, or not allowed: as the run's
            pass
        self._write(key, parts)

    def _write(self, key: str, parts: list) -> bool:
        parts = [_header(parts), *parts]
        try:
            self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            handle, temp = tempfile.mkstemp(prefix=f"{_TEMP_PREFIX}{key[:16]}-", suffix=".part", dir=self.folder)
        except OSError:
            return False
        try:
            with os.fdopen(handle, "wb") as out:
                for part in parts:
                    out.write(part)
                out.flush()
                os.fsync(out.fileno())
            os.replace(temp, self.path(key))
        except OSError:  # a full disk, a reader holding the file on Windows: no entry
            Path(temp).unlink(missing_ok=True)
            return False
        self.evict(keep=key)
        return True

    # ---------------------------------------------------------------- the folder

    def entries(self) -> list[CacheEntry]:
        """The entries, least recently used first."""
        found = []
        for path in self._files():
            try:
                stat = path.stat()
            except OSError:
                continue
            found.append(CacheEntry(path.stem, path, stat.st_size, stat.st_mtime, _description(path)))
        return sorted(found, key=lambda e: e.last_used)

    def _files(self) -> Iterator[Path]:
        if self.folder.is_dir():
            yield from (p for p in self.folder.iterdir() if p.suffix == _SUFFIX and not p.name.startswith("."))

    def total_bytes(self) -> int:
        return sum(e.size for e in self.entries())

    def evict(self, keep: str | None = None) -> int:
        """Remove the least recently used entries until the rest fit ``max_bytes`` (never
        ``keep``), and temporary files of writers that died; the number of entries removed."""
        self._remove_stale_temps()
        entries = []
        for path in self._files():
            try:
                stat = path.stat()
            except OSError:
                continue
            entries.append((stat.st_mtime, stat.st_size, path))
        entries.sort()
        total, removed = sum(size for _, size, _ in entries), 0
        for _, size, path in entries:
            if total <= self.max_bytes:
                break
            if path.stem == keep:
                continue
            path.unlink(missing_ok=True)
            total -= size
            removed += 1
        return removed

    def _remove_stale_temps(self) -> None:
        if not self.folder.is_dir():
            return
        now = time.time()
        for path in self.folder.glob(f"{_TEMP_PREFIX}*"):
            try:
                if now - path.stat().st_mtime > _STALE_TEMP_S:
                    path.unlink()
            except OSError:
                continue

    def clear(self) -> tuple[int, int]:
        """Remove every entry (and temporary file); ``(entries, bytes)`` removed."""
        count = size = 0
        for entry in self.entries():
            try:
                entry.path.unlink()
            except OSError:
                continue
            count, size = count + 1, size + entry.size
        if self.folder.is_dir():
            for path in self.folder.glob(f"{_TEMP_PREFIX}*"):
                path.unlink(missing_ok=True)
        return count, size


# -------------------------------------------------------------------- the file


def _encode(analysis: PhotoAnalysis, description: dict) -> list[bytes | memoryview]:
    """An entry's payload in parts (:func:`_header` goes before them): description, buffer
    table, pickle and buffers, each of the last two 64-byte aligned (an array read back is
    aligned as numba's kernels expect)."""
    buffers: list[pickle.PickleBuffer] = []
    body = pickle.dumps(analysis, protocol=5, buffer_callback=buffers.append)
    raws = [b.raw() for b in buffers]
    about = json.dumps(description, sort_keys=True, default=str).encode()
    table = struct.pack(f"<Q{len(raws)}Q", len(body), *(r.nbytes for r in raws))
    head_len = _HEADER.size + len(about) + len(table)
    parts: list[bytes | memoryview] = [about, table, b"\0" * _padding(head_len), body, b"\0" * _padding(len(body))]
    for raw in raws:
        parts += [raw, b"\0" * _padding(raw.nbytes)]
    return parts


def _length(part: bytes | memoryview) -> int:
    return len(part) if isinstance(part, bytes) else part.nbytes


def _header(parts: list[bytes | memoryview]) -> bytes:
    """The header of an entry whose payload is ``parts`` (:func:`_encode`): its length and CRC-32."""
    crc = 0
    for part in parts:
        crc = zlib.crc32(part, crc)
    about_len = len(parts[0])
    n_buffers = len(parts[1]) // 8 - 1  # (the table: the pickle's length, then each buffer's)
    return _HEADER.pack(_MAGIC, CACHE_FORMAT, n_buffers, about_len, sum(_length(p) for p in parts), crc)


def _read_whole(handle) -> memoryview | None:
    """An entry's bytes as one writable array (a numba kernel types a read-only array apart):
    on Linux mapped copy-on-write from the page cache and faulted in with one call (no copy;
    a read into fresh memory faulted 200 MB page by page, 0.5 s), else read in one go."""
    import mmap

    size = os.fstat(handle.fileno()).st_size
    if size < _HEADER.size:
        return None
    populate = getattr(mmap, "MAP_POPULATE", None)
    if populate is not None:
        mapped = mmap.mmap(
            handle.fileno(), size, flags=mmap.MAP_PRIVATE | populate, prot=mmap.PROT_READ | mmap.PROT_WRITE
        )
        return memoryview(mapped)
    data = np.empty(size, np.uint8).data
    return data if handle.readinto(data) == size else None


def _decode(data: memoryview) -> PhotoAnalysis | None:
    """An entry's analysis from its file's bytes (its arrays views of ``data``), or None when
    the file is not whole, not this format's, or does not unpickle."""
    if len(data) < _HEADER.size:
        return None
    magic, fmt, n_buffers, about_len, payload, crc = _HEADER.unpack_from(data, 0)
    if magic != _MAGIC or fmt != CACHE_FORMAT or len(data) != _HEADER.size + payload:
        return None
    if zlib.crc32(data[_HEADER.size :]) != crc:
        return None
    at = _HEADER.size + about_len
    lengths = struct.unpack_from(f"<Q{n_buffers}Q", data, at)
    at += 8 * (n_buffers + 1)
    at += _padding(at)
    body = data[at : at + lengths[0]]
    at += lengths[0] + _padding(lengths[0])
    buffers = []
    for n in lengths[1:]:
        buffers.append(data[at : at + n])
        at += n + _padding(n)
    if at != len(data):
        return None
    try:
        return pickle.loads(body, buffers=buffers)
    except Exception:  # noqa: BLE001 - a class that moved, a damaged pickle: a miss
        return None


def _description(path: Path) -> dict:
    """An entry's JSON description, from its header alone (not checked)."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(_HEADER.size)
            magic, fmt, _n, about_len, _payload, _crc = _HEADER.unpack(head)
            if magic != _MAGIC or fmt != CACHE_FORMAT or about_len > 1 << 16:
                return {}
            return json.loads(handle.read(about_len))
    except (OSError, ValueError, struct.error):
        return {}


# -------------------------------------------------------------------- the front ends' call


def open_store(enabled: bool = True) -> AnalysisStore | None:
    """The store the front ends use: None when ``enabled`` is false (``--no-cache``) or
    ``$BARKGEN_NO_CACHE`` is set, else :class:`AnalysisStore` of :func:`cache_folder`."""
    if not enabled or os.environ.get(ENV_OFF, "").strip() not in ("", "0"):
        return None
    return AnalysisStore()


def _describe(photo: np.ndarray, options: GenerateOptions, seconds: float) -> dict:
    h, w = np.shape(photo)[:2]
    key = {name: value for name, value in analysis_key(options)}
    key["size"] = f"{options.size[1]}x{options.size[0]}"
    return {"photo": f"{w}x{h}", "options": key, "seconds": round(seconds, 2), "made": round(time.time())}


def cached_analysis(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    scan: Any = None,
    cracks: Any = None,
    solvers: bool = True,
    store: AnalysisStore | None = None,
    progress: ProgressCallback | None = None,
    on_hit: Callable[[float], None] | None = None,
    wait: bool = True,
) -> PhotoAnalysis:
    """:func:`~barkgen.pipeline.analyze_photo` through ``store``: the stored analysis of the
    same inputs if there is one, else made and stored. Give it to
    :func:`~barkgen.pipeline.generate` (``analysis=``) for any seed: the same bytes as without it.

    Parameters
    ----------
    photo, options, extra, labels_in, scan, cracks, solvers, progress
        As for :func:`~barkgen.pipeline.analyze_photo`.
    store : AnalysisStore, optional
        None: no cache (the analysis is made).
    on_hit : callable, optional
        ``on_hit(seconds)`` when the analysis came from the store.
    wait : bool, default True
        False: a new analysis is written on a thread while the caller goes on
        (:meth:`AnalysisStore.put`; ``store.flush()`` waits for it).

    Returns
    -------
    PhotoAnalysis
        Its ``seconds`` what it cost this call (the read on a hit), its ``options`` ``options``.

    References
    ----------
    .. [1] mazzolini2012, §4.1.2 (the analysis phase depends on the exemplar alone).
    """
    from barkgen.pipeline.core import analyze_photo

    options = options or GenerateOptions()
    t0 = time.perf_counter()
    key = None
    if store is not None:
        try:
            key = analysis_digest(
                photo, options, extra=extra, labels_in=labels_in, scan=scan, cracks=cracks, solvers=solvers
            )
        except TypeError:  # an input the key cannot cover: no cache (never a wrong hit)
            store = None
    if store is not None and key is not None:
        found = store.get(key)
        if found is not None:
            seconds = time.perf_counter() - t0
            if on_hit is not None:
                on_hit(seconds)
            if progress is not None:
                progress(1000, 1000)
            return dataclasses.replace(found, options=options, seconds=seconds)
    analysis = analyze_photo(
        photo, options, extra=extra, labels_in=labels_in, progress=progress, scan=scan, solvers=solvers, cracks=cracks
    )
    if store is not None and key is not None:
        store.put(key, analysis, _describe(photo, options, analysis.seconds), wait=wait)
    return analysis
