"""The core and its extras (``pyproject.toml``): the algorithms run with none of the front ends'
dependencies loaded, and a front end whose extra is missing says which ``pip install`` brings it,
in one line."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

#: the import names each front end brings (barkgen._shared.extras.EXTRAS, written out again so
#: that a module moved between extras shows here)
FRONT_END_MODULES = (
    "typer",
    "rich",
    "fastapi",
    "uvicorn",
    "multipart",
    "distributed",
    "dask",
    "yaml",
    "bokeh",
    "trimesh",
    "MaterialX",
    "OpenEXR",
)

#: run first in a child Python: these top-level modules then cannot be found, as if not installed
BLOCK = textwrap.dedent("""
    import sys
    class _Block:
        def __init__(self, names):
            self.names = set(names)
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in self.names:
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None
    sys.meta_path.insert(0, _Block(sys.argv[1].split(",")))
    del sys.argv[1]
""")


def child(code: str, blocked: tuple[str, ...] = (), *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", BLOCK + textwrap.dedent(code), ",".join(blocked) or "-", *args],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_the_core_synthesizes_and_makes_materials_without_any_front_end():
    result = child(
        """
        import json, sys
        import numpy as np
        import barkgen
        photo = np.asarray(barkgen.read_image(barkgen.sample_exemplar_path()))[::8, ::8]
        texture = barkgen.synthesize(photo, 64, tile=True, seed=0)
        material = barkgen.make_material(texture.image)
        print(json.dumps({"shape": list(texture.image.shape), "height": list(material.height.shape),
                          "loaded": sorted(m for m in sys.modules if m.split(".")[0] in sys.argv[1:])}))
    """,
        FRONT_END_MODULES,
        *FRONT_END_MODULES,
    )
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout.strip().splitlines()[-1])
    assert out["shape"] == [64, 64, 3] and out["height"] == [64, 64]
    assert out["loaded"] == []


def test_synthesize_imports_no_front_end_even_when_all_are_installed():
    result = child(
        """
        import json, sys
        import numpy as np
        import barkgen
        photo = np.asarray(barkgen.read_image(barkgen.sample_exemplar_path()))[::8, ::8]
        barkgen.synthesize(photo, 48, seed=1)
        print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in sys.argv[1:])))
    """,
        (),
        *[m for m in FRONT_END_MODULES if m != "yaml"],
    )  # numba reads its config with yaml
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.strip().splitlines()[-1]) == []


@pytest.mark.parametrize(
    "blocked, argv, extra",
    [
        (("typer",), ["--help"], "cli"),
        (("rich",), ["synth", "--help"], "cli"),
        (("fastapi",), ["serve", "--port", "0"], "web"),
        (("distributed",), ["batch", "spec.yaml", "-o", "out"], "batch"),
        (("yaml",), ["batch", "spec.yaml", "-o", "out"], "batch"),
    ],
)
def test_a_front_end_without_its_extra_names_the_install_in_one_line(tmp_path, blocked, argv, extra):
    result = subprocess.run(
        [sys.executable, "-c", BLOCK + "from barkgen.cli import main\nmain(sys.argv[1:])", ",".join(blocked), *argv],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith("barkgen: error: ")
    assert f"pip install 'barkgen[{extra}]'" in lines[0] and blocked[0] in lines[0]
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_gltf_export_without_its_extra_says_so():
    result = child(
        """
        from barkgen.errors import MissingExtraError
        from barkgen.io import encode_glb
        try:
            encode_glb(None, None)
        except MissingExtraError as exc:
            print(exc)
    """,
        ("trimesh",),
    )
    assert result.returncode == 0, result.stderr
    assert "pip install 'barkgen[gltf]'" in result.stdout


def test_the_package_face_lists_its_public_names():
    import barkgen
    from barkgen._version import __version__

    names = dir(barkgen)
    assert set(barkgen.__all__) <= set(names)
    assert {"synthesize", "generate", "make_material", "SynthesisConfig"} <= set(names)
    assert barkgen.__version__ == __version__
    from importlib.metadata import version

    assert version("barkgen") == __version__  # pyproject reads the same source
