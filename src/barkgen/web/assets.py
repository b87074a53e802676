"""The web app's third-party browser assets, from the npm registry: three.js (MIT) for the
WebGL trunk. They are not kept in the repository; ``python -m barkgen.web.assets`` (run by the
README's set-up scripts, and by the wheel's build: ``setup.py``) downloads the pinned release,
checks it against the registry's published SHA-512 integrity, and unpacks the files the pages
use, with three.js' licence, into ``static/vendor/three/``. Without them the pages work, the 3D
panel says what is missing and ``barkgen serve`` says so at start (:func:`missing_warning`).

This module uses the standard library only: the build loads it from its file."""

from __future__ import annotations

import base64
import hashlib
import io
import os
import sys
import tarfile
import tempfile
import urllib.request
from pathlib import Path

THREE_VERSION = "0.187.0"
THREE_TARBALL = f"https://registry.npmjs.org/three/-/three-{THREE_VERSION}.tgz"
#: ``npm view three@0.187.0 dist.integrity``
THREE_INTEGRITY = "sha512-Qiu7R+Cmh8CstZsY1uJOSWnVlfo7ZtNLV7mF8Jltk3LB3AtDu9cRZlcnRKkAk8Y4z6KKw35z7Y7Urd7jWY8etA=="
#: package path -> path under vendor/three
THREE_FILES = {
    "package/build/three.module.js": "three.module.js",
    "package/build/three.core.js": "three.core.js",
    "package/examples/jsm/controls/OrbitControls.js": "addons/controls/OrbitControls.js",
    "package/LICENSE": "LICENSE",
}
VENDOR = Path(__file__).parent / "static" / "vendor" / "three"


def assets_present(folder: Path = VENDOR) -> bool:
    """True when every vendored file is there, of the pinned version."""
    stamp = folder / "VERSION"
    return (
        stamp.is_file()
        and stamp.read_text().strip() == THREE_VERSION
        and all((folder / target).is_file() for target in THREE_FILES.values())
    )


def missing_warning(folder: Path | None = None) -> str | None:
    """The line ``barkgen serve`` prints at start when three.js is not in ``folder`` (default
    :data:`VENDOR`), or None."""
    folder = VENDOR if folder is None else folder
    if assets_present(folder):
        return None
    return (
        f"barkgen: warning: three.js {THREE_VERSION} is missing from {folder}, so the web "
        "app's 3D trunk view is off; `python -m barkgen.web.assets` fetches it"
    )


def fetch_three(folder: Path = VENDOR, *, url: str = THREE_TARBALL, timeout: float = 60.0) -> Path:
    """Download three.js from the npm registry, check its integrity and unpack the files the
    pages use into ``folder`` (each file renamed into place, the version stamp last)."""
    with urllib.request.urlopen(url, timeout=timeout) as response:  # noqa: S310 - fixed https URL
        data = response.read()
    algorithm, expected = THREE_INTEGRITY.split("-", 1)
    digest = base64.b64encode(hashlib.new(algorithm, data).digest()).decode()
    if digest != expected:
        raise RuntimeError(f"{url}: integrity check failed (got {algorithm}-{digest})")
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as archive:
        members = {m.name: m for m in archive.getmembers() if m.name in THREE_FILES}
        missing = sorted(set(THREE_FILES) - set(members))
        if missing:
            raise RuntimeError(f"{url}: the package lacks {missing[0]}")
        for name, target in THREE_FILES.items():
            path = folder / target
            path.parent.mkdir(parents=True, exist_ok=True)
            member = archive.extractfile(members[name])
            assert member is not None  # THREE_FILES are regular files
            content = member.read()
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
            with os.fdopen(fd, "wb") as fh:
                fh.write(content)
            os.chmod(tmp, 0o644)
            os.replace(tmp, path)
    (folder / "VERSION").write_text(THREE_VERSION + "\n")
    return folder


def main() -> int:
    if assets_present():
        return 0
    try:
        fetch_three()
    except Exception as exc:  # network down, registry refused, ...: one line
        print(
            f"barkgen: warning: could not fetch three.js {THREE_VERSION} from the npm registry "
            f"({exc}); the web app's 3D trunk view will be off",
            file=sys.stderr,
        )
        return 1
    print(f"barkgen: three.js {THREE_VERSION} (MIT) -> {VENDOR}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
