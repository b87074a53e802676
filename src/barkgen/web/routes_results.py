"""The web app's results: listed, shown (files, material maps, label-map levels in the label
colours with a legend of what each label is in the photo) and removed, and downloaded as a zip
with a README of its files.

Each endpoint wraps a plain function of the same module that takes the app's
:class:`~barkgen.web.state.AppState`; they raise barkgen's errors, which :mod:`barkgen.web.app`
answers with their HTTP codes.
"""

from __future__ import annotations

import io
import json
import re
import zipfile
from pathlib import Path

import numpy as np
from fastapi import APIRouter
from fastapi.responses import Response

from barkgen.io import decode_image, encode_png
from barkgen.io.asset_names import asset_slug, base_name, library_file_name, material_set_name
from barkgen.labels import label_colour_map
from barkgen.labels.preview import label_colours
from barkgen.library import NotFoundError
from barkgen.pipeline import GenerateOptions
from barkgen.web.state import LABEL_METHOD, AppState, State, cached_response

router = APIRouter()

_MEDIA = {".png": "image/png", ".jpg": "image/jpeg", ".json": "application/json", ".glb": "model/gltf-binary"}

#: the keys of a set's ``NAME.json`` the page's trunk and sliders read
_RECORD_KEYS = (
    "displacement_depth_px",
    "displacement_midlevel",
    "displacement_depth_m",
    "width_m",
    "height_m",
    "real_size",
    "light_equalization",
)

_FILE_NOTES = {
    "_Color.png": "base colour (sRGB), shading removed",
    "_NormalGL.png": "normal map, OpenGL convention (Y up: Blender, Unity, three.js)",
    "_NormalDX.png": "normal map, DirectX convention (Y down: Unreal, Substance)",
    "_Displacement.png": "height, 16-bit, 0 = deepest (depth in the .json)",
    "_Roughness.png": "roughness (linear)",
    "_AmbientOcclusion.png": "ambient occlusion (linear)",
    ".json": "the material set's record: size, tileable, seed, source photo, displacement depth",
    "_blender.py": "the set in Blender at its real-world size: blender --python it (or Run Script in the Text Editor)",
    "texture.png": "the new bark, as synthesized (before shading removal)",
    "labels_in.png": "the photo's label map (one grey value per region type)",
    "labels_out.png": "the new bark's label map (same grey values)",
    "reference.png": "16-bit: for each output pixel, the photo pixel (x, y) it copies "
    "(barkgen apply-reference re-applies it to any map of the photo)",
    "preview.png": "contact sheet: photo, labels in, labels out, result",
    "report.json": "parameters, seed, label areas and timings of the run",
    "edits.json": "the relief editor's height edits, depth and photo light that made this set from its parent "
    "(barkgen generate --material --edits FILE replays them)",
    "illumination.png": "16-bit: the photo's broad light carried to the new bark (log2, mid-grey = 1; "
    "barkgen.material.decode_illumination)",
    "trunk.glb": "the bark on a trunk, glTF 2.0 binary with its material (Blender, three.js, game engines)",
    "README.txt": "this file",
}
#: the run's own files of a result that are no download (its page's pictures)
_PAGE_ONLY = ("thumbnail.jpg",)


def set_name(result, exemplar) -> str:
    """The name a result's downloads carry: its material set's (``ASSET_VARIANT_SIZE``,
    :mod:`barkgen.io.asset_names`; a result without a set: the name its set would have). A
    result made before the sets carried their size: its set's old name (``oak_seed7``), else
    the photo's name, its seed and size."""
    if result.params.get("set_name"):
        return str(result.params["set_name"])
    legacy = next((n[: -len("_Color.png")] for n in result.files if n.endswith("_Color.png")), None)
    width, height = result.params["size"]
    return legacy or material_set_name(base_name(asset_slug(exemplar.name), f"seed{result.seed}"), (height, width))


def download_names(result, exemplar) -> dict[str, str]:
    """Each downloaded file of a result (its own name -> its name in a download): every file
    carries the set's name (:func:`set_name`; ``SET_texture.png``, ``SET_trunk.glb``, the set's
    own files as they are), the page's pictures and label-map levels left out."""
    name = set_name(result, exemplar)
    kept = [n for n in sorted(result.files) if not n.startswith("level_") and n not in _PAGE_ONLY]
    return {n: library_file_name(name, n) for n in kept}


def result_summary(result) -> dict:
    """A result as lists show it."""
    return {
        "id": result.id,
        "exemplar_id": result.exemplar_id,
        "created": result.created,
        "params": result.params,
        "thumbnail_url": f"/api/results/{result.id}/files/thumbnail.jpg",
    }


def _label_values(state: AppState, result_id: int) -> np.ndarray:
    """The grey values of a result's labels (those of its input label map)."""
    return np.unique(decode_image(state.library.result_file(result_id, "labels_in.png"), "labels"))


def _levels(state: AppState, result, base: str) -> list[dict]:
    """The levels of a result's output label map (``level_N.png``): number, size, URL."""
    from PIL import Image

    levels, sizes = [], []
    for name in sorted(result.files):
        m = re.fullmatch(r"level_(\d+)\.png", name)
        if m:
            levels.append(int(m.group(1)))
            with Image.open(io.BytesIO(state.library.result_file(result.id, name))) as header:
                sizes.append(header.size)
    return [
        {"level": n, "width": w, "height": h, "url": f"{base}/labels/level_{n}.png"}
        for n, (w, h) in sorted(zip(levels, sizes))
    ]


def result_json(state: AppState, result) -> dict:
    """A result as its page shows it: files, material maps, levels, palette and legend, and its
    downloads with the names they are saved under (``downloads``)."""
    base = f"/api/results/{result.id}"
    exemplar = state.library.exemplar(result.exemplar_id)
    files = {name: f"{base}/files/{name}" for name in result.files}
    material_name = next((n[: -len("_Color.png")] for n in result.files if n.endswith("_Color.png")), None)
    maps = None
    meta: dict = {}
    if material_name is not None:
        from barkgen.io import MAP_SUFFIXES

        maps = {suffix: files[f"{material_name}_{suffix}.png"] for suffix in MAP_SUFFIXES}
        meta = json.loads(state.library.result_file(result.id, f"{material_name}.json"))
    levels = _levels(state, result, base)
    values = _label_values(state, result.id)
    return {
        **result_summary(result),
        "timings": result.timings,
        "parent_id": result.parent_id,
        "files": files,
        "labels_in_url": f"{base}/labels/labels_in.png",
        "labels_out_url": f"{base}/labels/labels_out.png",
        "maps": maps,
        "displacement_depth_px": meta.get("displacement_depth_px"),
        "material": _material_record(result, meta) if maps is not None else None,
        "levels": levels,
        "palette": label_colours(values.size).tolist(),
        "label_looks": label_looks(state, result.exemplar_id, result.id, values),
        "download_url": f"{base}/download",
        "set_name": set_name(result, exemplar),
        "downloads": _downloads(result, exemplar, base),
    }


def _downloads(result, exemplar, base: str) -> dict:
    """The page's download buttons: the zip, the trunk (``SET_trunk.glb``) and the set with its
    Blender set-up (a zip of the material set and ``SET_blender.py``), each ``{"url", "name"}``
    (None where the result has no such file)."""
    name = set_name(result, exemplar)
    names = download_names(result, exemplar)
    glb = {"url": f"{base}/files/trunk.glb", "name": names["trunk.glb"]} if "trunk.glb" in names else None
    script = next((n for n in result.files if n.endswith("_blender.py")), None)
    blender = {"url": f"{base}/download/blender", "name": f"{name}_blender.zip"} if script else None
    return {"zip": {"url": f"{base}/download", "name": f"{name}.zip"}, "glb": glb, "blender": blender}


def _material_record(result, meta: dict) -> dict:
    """What the page's trunk and its Depth and Photo light sliders need of a result's set: its
    ``NAME.json``'s depth, midlevel, real size (``None`` where the set predates them), the light
    taken out of its colour and of its ``texture.png`` (the run's), and where the photo's light
    is (``illumination_url``: ``None`` for a result made before barkgen kept it)."""
    from barkgen.pipeline.files import ILLUMINATION_FILE

    run_light = result.params.get("equalize_light", GenerateOptions().equalize_light)
    return {
        **{key: meta.get(key) for key in _RECORD_KEYS},
        "texture_light_equalization": run_light,
        "illumination_url": f"/api/results/{result.id}/illumination" if ILLUMINATION_FILE in result.files else None,
    }


def label_looks(state: AppState, exemplar_id: int, result_id: int, values: np.ndarray) -> list[dict]:
    """What each label is in the photo: its mean colour and its share of the photo (the
    legend of the label colours), cached in the library's analyses."""
    library = state.library
    key = {"values": [int(v) for v in values], "method": LABEL_METHOD}
    cached = library.analysis(exemplar_id, "label_looks", key)
    if cached is not None:
        return json.loads(cached)
    from barkgen._shared.arrays import as_uint8

    photo = as_uint8(library.photo(exemplar_id)).astype(np.float64)
    photo = np.broadcast_to(photo, photo.shape[:2] + (3,))
    grey = decode_image(library.result_file(result_id, "labels_in.png"), "labels")[..., 0]
    looks = []
    for value in values:
        inside = grey == value
        mean = photo[inside].mean(axis=0) if inside.any() else np.zeros(3)
        looks.append({"colour": [int(round(c)) for c in mean], "share": round(float(inside.mean()), 4)})
    library.put_analysis(exemplar_id, "label_looks", key, json.dumps(looks).encode())
    return looks


def all_results(state: AppState) -> list[dict]:
    return [result_summary(r) for r in state.library.results()]


def result_details(state: AppState, result_id: int) -> dict:
    return result_json(state, state.library.result(result_id))


def delete_result(state: AppState, result_id: int) -> dict:
    state.library.remove_result(result_id)
    return {"removed": result_id}


def coloured_result_labels(state: AppState, result_id: int, name: str) -> bytes:
    """A label map of the result (``labels_in.png``, ``labels_out.png``, ``level_N.png``)
    in the label colours (those of ``palette``), as a PNG."""
    if not re.fullmatch(r"labels_in\.png|labels_out\.png|level_\d+\.png", name):
        raise NotFoundError(f"no label map {name!r}")
    values = _label_values(state, result_id)
    grey = decode_image(state.library.result_file(result_id, name), name)[..., 0]
    return encode_png(label_colour_map(grey, values))


def _file_note(name: str) -> str:
    """What a result's file (by its own name) is, for the README."""
    if name in _FILE_NOTES:
        return _FILE_NOTES[name]
    if name.endswith(".json"):  # the set's NAME.json (the run's report and edits are named above)
        return _FILE_NOTES[".json"]
    return next((text for key, text in _FILE_NOTES.items() if key.startswith("_") and name.endswith(key)), "")


def zip_readme(exemplar, result, names: dict[str, str]) -> str:
    """What each file of a downloaded result is (``names``: its own name -> its name in the
    zip), and the photo's licence and source as given at its upload (the new bark is made of
    the photo's pixels: its licence goes with it)."""
    width, height = result.params["size"]
    lines = [
        f'barkgen result {result.id}: {width}x{height} px from "{exemplar.name}", seed {result.params["seed"]}'
        f"{', tileable' if result.params.get('tile') else ''}.",
        f"Photo licence: {exemplar.licence or 'not given at upload'}",
    ]
    if exemplar.source:
        lines.append(f"Photo source: {exemplar.source}")
    relief = result.params.get("relief_from")
    if relief:
        lines.append(
            f"Relief-edited from result {relief['result_id']}: its {_relief_name(names)} lists the edits, depth and light."
        )
    lines.append("")
    column = max(40, *(len(n) + 1 for n in names.values()))
    for own, name in names.items():
        lines.append(f"{name:{column}s} {_file_note(own)}".rstrip())
    return "\n".join(lines) + "\n"


def _relief_name(names: dict[str, str]) -> str:
    return names.get("edits.json", "edits.json")


def result_zip(state: AppState, result_id: int, part: str = "all") -> tuple[str, bytes]:
    """The result as a zip and its file name, every file named as an artist's library expects
    (:func:`download_names`): ``SET.zip`` of the material set when it has one, the texture,
    its label maps, reference map, contact sheet, report, trunk and README (``SET_README.txt``);
    ``part="blender"``: ``SET_blender.zip``, the material set and its Blender set-up
    (``SET_blender.py``, run where the maps are) with the README."""
    library = state.library
    result = library.result(result_id)
    exemplar = library.exemplar(result.exemplar_id)
    name = set_name(result, exemplar)
    names = download_names(result, exemplar)
    if part == "blender":
        names = {own: n for own, n in names.items() if n.startswith((f"{name}_", f"{name}.")) and n == own}
        if not any(n.endswith("_blender.py") for n in names):
            raise NotFoundError(f"result {result_id} has no material set with a Blender set-up")
    names[_README] = library_file_name(name, _README)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for own, zipped in names.items():
            if own != _README:
                archive.writestr(zipped, library.result_file(result_id, own))
        archive.writestr(names[_README], zip_readme(exemplar, result, names))
    return f"{name}_blender.zip" if part == "blender" else f"{name}.zip", buffer.getvalue()


_README = "README.txt"


# -- endpoints ------------------------------------------------------------------------------
@router.get("/api/results")
def list_results(state: State):
    return all_results(state)


@router.get("/api/results/{result_id}")
def get_result(result_id: int, state: State):
    return result_details(state, result_id)


@router.delete("/api/results/{result_id}")
def remove_result(result_id: int, state: State):
    return delete_result(state, result_id)


@router.get("/api/results/{result_id}/files/{name}")
def result_file(result_id: int, name: str, state: State):
    data = state.library.result_file(result_id, name)  # a name of the result's own list, or 404
    return cached_response(data, _MEDIA.get(Path(name).suffix, "application/octet-stream"))


@router.get("/api/results/{result_id}/labels/{name}")
def result_labels(result_id: int, name: str, state: State):
    """A label map of the result (``labels_in.png``, ``labels_out.png``, ``level_N.png``)
    in the label colours (those of ``palette``)."""
    return cached_response(coloured_result_labels(state, result_id, name), "image/png")


def _zip_response(filename: str, data: bytes) -> Response:
    return Response(
        data, media_type="application/zip", headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )


@router.get("/api/results/{result_id}/download")
def download(result_id: int, state: State):
    """The result as ``SET.zip``: the material set when it has one, the texture, its label
    maps, reference map, contact sheet, report and trunk, each named ``SET_...``."""
    return _zip_response(*result_zip(state, result_id))


@router.get("/api/results/{result_id}/download/blender")
def download_blender(result_id: int, state: State):
    """The material set with its Blender set-up as ``SET_blender.zip`` (unzip, then
    ``blender --python SET_blender.py``)."""
    return _zip_response(*result_zip(state, result_id, "blender"))
