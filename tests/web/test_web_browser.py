"""The web app in a real browser: Debian's Chromium driven by Playwright against `barkgen serve`
on loopback. Upload a bark photo of tests/data, generate 512², watch the progress move and the result
appear, see the 3D trunk draw, paint a stroke on the label map and continue, download the zip.

Chromium comes from Debian's package (``scripts/test.sh`` installs it); Playwright never downloads
a browser. Without /usr/bin/chromium the test is skipped, except under CI, where it fails.
Screenshots go to ``$BARKGEN_SHOTS`` when it is set."""

from __future__ import annotations

import io
import os
import re
import socket
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import BARK, BARK_MAPS, crack_photo_file

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
SHOTS = os.environ.get("BARKGEN_SHOTS")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`barkgen serve` on a new library, as a user starts it; yields its address."""
    port = _free_port()
    library = tmp_path_factory.mktemp("weblib")
    log = open(tmp_path_factory.mktemp("weblog") / "serve.log", "w+")
    process = subprocess.Popen(
        [sys.executable, "-m", "barkgen", "serve", "--port", str(port), "--library", str(library)],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while True:
        log.seek(0)
        if "barkgen is running at" in log.read():
            break
        if process.poll() is not None or time.monotonic() > deadline:
            log.seek(0)
            process.kill()
            output = log.read()
            log.close()
            pytest.fail(f"barkgen serve did not start:\n{output}")
        time.sleep(0.2)
    log.seek(0)
    assert f"running at {url}" in log.read()
    yield url
    process.terminate()
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        pytest.fail("barkgen serve did not stop within 30 s of SIGTERM")
    finally:
        log.close()


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        if os.environ.get("CI"):
            pytest.fail("the browser tests need Debian's chromium (/usr/bin/chromium); scripts/test.sh installs it")
        pytest.skip("needs Debian's chromium at /usr/bin/chromium (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


def _shot(page, name: str, **kwargs) -> None:
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(Path(SHOTS) / f"{name}.png"), **kwargs)


def _follow_job(page, timeout_s: float = 240) -> list[float]:
    """The job panel's progress values seen until the page moves to a result."""
    seen = []
    start = page.url.split("?")[0]
    deadline = time.monotonic() + timeout_s
    progress = page.get_by_test_id("job-progress")
    while page.url.split("?")[0] == start or "/results/" not in page.url:
        try:  # the page's own address and progress, read together (it may be navigating)
            where, value = progress.evaluate("el => [location.href, el.value]", timeout=2000)
            if where.split("?")[0] == start:
                seen.append(float(value))
        except Exception:
            pass
        try:
            state = page.get_by_test_id("job-state").first.text_content(timeout=2000) or ""
        except Exception:
            state = ""
        if state.startswith("failed"):
            pytest.fail(f"job {state}")
        assert time.monotonic() < deadline, f"no result after {timeout_s} s; progress seen {seen[-5:]}"
        page.wait_for_timeout(150)
    return seen


def _canvas_pixels(page, testid: str) -> np.ndarray:
    from PIL import Image

    png = page.get_by_test_id(testid).screenshot()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float32)


def test_upload_generate_view_paint_continue_download(server, browser, tmp_path):
    photo = BARK / "oak_furrowed_moss_01.jpg"
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(server)
    # the bundled sample is in the library from the first start
    page.get_by_test_id("exemplar-card").first.wait_for()
    _shot(page, "1_library")

    # upload a photo of tests/data: the app moves to its page
    page.get_by_test_id("upload-file").set_input_files(str(photo))
    page.get_by_test_id("upload-name").fill("oak in the browser")
    page.get_by_test_id("upload-submit").click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.get_by_test_id("exemplar-photo").wait_for()
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=labels-in]');"
        " return i && i.complete && i.naturalWidth > 0; }",
        timeout=60_000,
    )
    page.get_by_test_id("param-size").select_option("512x512")
    page.get_by_test_id("param-seed").fill("3")
    assert page.get_by_test_id("param-material").is_checked()  # the form's default (the quickstart's)
    _shot(page, "2_exemplar")

    # generate: the progress moves, then the result page shows the texture
    page.get_by_test_id("generate").click()
    seen = _follow_job(page)
    assert any(0 < value < 1 for value in seen), f"progress never moved between 0 and 1: {seen}"
    assert seen == sorted(seen), "progress went backwards"
    first_result = page.url
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=result-texture]');"
        " return i && i.complete && i.naturalWidth === 512; }",
        timeout=30_000,
    )

    # the 3D trunk draws (WebGL through SwiftShader): its pixels are not blank
    page.wait_for_selector("[data-testid=trunk-canvas][data-ready='1']", timeout=60_000)
    page.wait_for_timeout(500)
    trunk = _canvas_pixels(page, "trunk-canvas")
    assert trunk.std() > 10, f"the trunk canvas looks blank (std {trunk.std():.1f})"
    assert np.unique(trunk.reshape(-1, 3).astype(np.uint8), axis=0).shape[0] > 500
    # the light slider changes the picture
    page.get_by_test_id("light-azimuth").evaluate(
        "el => { el.value = 220; el.dispatchEvent(new Event('input', {bubbles: true})); }"
    )
    page.wait_for_timeout(500)
    relit = _canvas_pixels(page, "trunk-canvas")
    assert np.abs(relit - trunk).mean() > 1.0, "moving the light changed nothing"
    _shot(page, "3_result", full_page=True)

    # download the material set: ambientCG names inside, each file named after the set
    with page.expect_download() as download_info:
        page.get_by_test_id("download").click()
    set_name = "oak-in-the-browser_seed3_512x512"
    assert download_info.value.suggested_filename == f"{set_name}.zip"
    archive = tmp_path / "set.zip"
    download_info.value.save_as(archive)
    names = zipfile.ZipFile(archive).namelist()
    for suffix in ("Color", "NormalGL", "NormalDX", "Displacement", "Roughness", "AmbientOcclusion"):
        assert f"{set_name}_{suffix}.png" in names, (suffix, names)
    assert f"{set_name}_texture.png" in names and f"{set_name}_report.json" in names

    # paint one stroke of label 0 across the chosen level, then continue synthesis from it
    canvas = page.get_by_test_id("paint-canvas")
    canvas.scroll_into_view_if_needed()
    page.get_by_test_id("paint-swatch").first.click()
    page.get_by_test_id("paint-radius").fill("4")
    before = canvas.evaluate("c => c.toDataURL()")
    box = canvas.bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.2, box["y"] + box["height"] * 0.5)
    page.mouse.down()
    for step in range(1, 21):
        page.mouse.move(box["x"] + box["width"] * (0.2 + 0.03 * step), box["y"] + box["height"] * 0.5)
    page.mouse.up()
    assert canvas.evaluate("c => c.toDataURL()") != before, "the stroke did not paint"
    _shot(page, "4_painted", full_page=True)
    page.get_by_test_id("paint-continue").click()
    _follow_job(page)
    page.wait_for_url(lambda url: "/results/" in url and url.split("?")[0] != first_result.split("?")[0])
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=result-texture]');"
        " return i && i.complete && i.naturalWidth === 512; }",
        timeout=30_000,
    )
    _shot(page, "5_continued", full_page=True)

    # the continued result starts from the painted level and differs from the first
    first_id = int(re.search(r"/results/(\d+)", first_result).group(1))
    second_id = int(re.search(r"/results/(\d+)", page.url).group(1))
    second = page.request.get(f"{server}api/results/{second_id}").json()
    assert second["params"]["resumed_from"]["result_id"] == first_id
    texture_a = page.request.get(f"{server}api/results/{first_id}/files/texture.png").body()
    texture_b = page.request.get(f"{server}api/results/{second_id}/files/texture.png").body()
    assert texture_a != texture_b
    labels_a = page.request.get(f"{server}api/results/{first_id}/files/labels_out.png").body()
    labels_b = page.request.get(f"{server}api/results/{second_id}/files/labels_out.png").body()
    assert labels_a != labels_b
    assert not errors, f"JavaScript errors: {errors}"
    page.close()


def test_reload_finds_the_job_and_cancel(server, browser):
    """A page reload reconnects to its job; cancel stops it."""
    page = browser.new_page()
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.get_by_test_id("param-size").select_option("1024x1024")
    page.get_by_test_id("generate").click()
    page.wait_for_url(re.compile(r"[?&]job="))
    job_url = page.url
    page.reload()
    assert page.url == job_url
    page.get_by_test_id("job-state").wait_for()
    page.wait_for_function("() => /queued|running/.test(document.querySelector('[data-testid=job-state]').textContent)")
    page.get_by_test_id("job-cancel").click()
    page.wait_for_function(
        "() => /cancelled/.test(document.querySelector('[data-testid=job-state]').textContent)", timeout=30_000
    )
    job_id = re.search(r"job=([0-9a-f]+)", job_url).group(1)
    assert page.request.get(f"{server}api/jobs/{job_id}").json()["state"] == "cancelled"
    page.close()


def test_a_scanned_sets_zip_is_uploaded_and_its_maps_make_the_material(server, browser, tmp_path):
    """A zip of a real scan (willow: colour, normal, AO, roughness) through the upload form: the
    photo's page says it is a set, and a result's roughness is the scan's (not an estimate)."""
    import zipfile

    maps = BARK_MAPS
    archive = tmp_path / "willow_furrowed_01_1k.zip"
    with zipfile.ZipFile(archive, "w") as zipped:
        zipped.write(BARK / "willow_furrowed_01.jpg", "willow_furrowed_01/willow_furrowed_01.jpg")
        for kind in ("normal", "ao", "roughness"):
            zipped.write(maps / f"willow_furrowed_01_{kind}.jpg", f"willow_furrowed_01/willow_furrowed_01_{kind}.jpg")
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    page.goto(server)
    page.get_by_test_id("upload-file").set_input_files(str(archive))
    page.get_by_test_id("upload-submit").click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    meta = page.get_by_test_id("exemplar-meta")
    page.wait_for_function(
        "() => /scanned set/.test(document.querySelector('[data-testid=exemplar-meta]').textContent)"
    )
    assert "scanned set: colour + AO, normal, roughness" in meta.text_content()
    assert page.get_by_test_id("exemplar-name").text_content() == "willow_furrowed_01"
    assert "the set's own maps" in page.get_by_test_id("material-hint").text_content()
    page.get_by_test_id("param-size").select_option("256x256")
    page.get_by_test_id("generate").click()
    _follow_job(page)
    result_id = re.search(r"/results/(\d+)", page.url).group(1)
    result = page.request.get(f"{server}api/results/{result_id}").json()
    from barkgen.io import decode_image

    name = next(n for n in result["files"] if n.endswith("_Roughness.png"))
    out = decode_image(page.request.get(f"{server}{result['files'][name].lstrip('/')}").body())[..., 0]
    scan = decode_image((maps / "willow_furrowed_01_roughness.jpg").read_bytes())[..., 0]
    # the scan's own values (an estimate from the colour would not share its histogram)
    share = np.isin(out, np.unique(scan)).mean()
    assert share > 0.99 and abs(float(out.mean()) - float(scan.mean())) < 8, (share, out.mean(), scan.mean())
    page.close()


def _upload(page, server: str, path: Path, name: str, licence: str = "") -> None:
    page.goto(server)
    page.get_by_test_id("upload-file").set_input_files(str(path))
    page.get_by_test_id("upload-name").fill(name)
    if licence:
        page.get_by_test_id("upload-licence").fill(licence)
    page.get_by_test_id("upload-submit").click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.get_by_test_id("exemplar-photo").wait_for()


def test_cracks_and_bilayer_from_the_form_with_every_control(server, browser, tmp_path):
    """A photo of dried mud: the page says it has cracks to grow from; the form's every control
    (kind, any W x H, k up to 8, method, strategy, relief, layout) goes into the job; the crack
    result's page says so, offers its trunk as a glb and a zip named after the photo with its
    licence; then a bi-layer texture of the same photo. A flat photo is told why it has no
    cracks to grow."""
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    _upload(page, server, crack_photo_file(256, 0, cell=32), "Dried mud", "CC0")
    hint = page.get_by_test_id("param-kind-hint")
    page.wait_for_selector("[data-testid=param-kind][data-kinds='1']", timeout=60_000)
    page.get_by_test_id("param-kind").select_option("cracks")
    assert "crack branches found" in hint.text_content()
    assert page.get_by_test_id("param-k").is_disabled()
    # the CLI's defaults, then a custom size and the rest
    assert (
        page.get_by_test_id("param-width").input_value() == "1024"
        and not page.get_by_test_id("param-tile").is_checked()
    )
    page.get_by_test_id("param-size").select_option("custom")
    page.get_by_test_id("param-width").fill("192")
    page.get_by_test_id("param-height").fill("128")
    page.get_by_test_id("param-tile").check()
    page.get_by_test_id("param-material").check()
    page.get_by_test_id("more-settings").locator(":scope > summary").click()
    page.get_by_test_id("param-relief").evaluate(
        "el => { el.value = 1.5; el.dispatchEvent(new Event('input', {bubbles: true})); }"
    )
    page.get_by_test_id("param-preset").select_option("gltf")
    page.get_by_test_id("param-seed").fill("11")
    _shot(page, "web_cracks_form_1366x768")
    page.get_by_test_id("generate").click()
    stages = set()
    start = time.monotonic()
    while "/results/" not in page.url and time.monotonic() - start < 240:
        try:
            text = page.get_by_test_id("job-state").first.text_content(timeout=1000) or ""
        except Exception:
            text = ""
        assert not text.startswith("failed"), text
        if "—" in text:
            stages.add(text.split("—", 1)[1].strip())
        page.wait_for_timeout(100)
    page.wait_for_url(re.compile(r"/results/\d+"))
    assert stages, "the job never named its stage"
    result_id = int(re.search(r"/results/(\d+)", page.url).group(1))
    result = page.request.get(f"{server}api/results/{result_id}").json()
    params = result["params"]
    assert params["size"] == [192, 128] and params["structure"] == "cracks" and params["relief"] == 1.5
    assert params["preset"] == "gltf" and params["seed"] == 11
    page.get_by_test_id("result-params").wait_for()
    assert "cracks" in page.get_by_test_id("result-params").text_content()
    assert "not painted" in page.get_by_test_id("painter").text_content()
    glb_link = page.get_by_test_id("download-glb")
    assert glb_link.is_visible()
    set_name = "Dried-mud_seed11_192x128"  # every download named after the set (issue 66)
    with page.expect_download() as info:
        glb_link.click()
    assert info.value.suggested_filename == f"{set_name}_trunk.glb"
    glb = tmp_path / "trunk.glb"
    info.value.save_as(glb)
    assert glb.read_bytes()[:4] == b"glTF"
    with page.expect_download() as info:
        page.get_by_test_id("download").click()
    assert info.value.suggested_filename == f"{set_name}.zip"
    archive = tmp_path / "set.zip"
    info.value.save_as(archive)
    assert "Photo licence: CC0" in zipfile.ZipFile(archive).read(f"{set_name}_README.txt").decode()
    # the set with its Blender set-up (gltf preset: its script reads the set's packed maps)
    with page.expect_download() as info:
        page.get_by_test_id("download-blender").click()
    assert info.value.suggested_filename == f"{set_name}_blender.zip"
    blender = tmp_path / "blender.zip"
    info.value.save_as(blender)
    assert f"{set_name}_blender.py" in zipfile.ZipFile(blender).namelist()
    _shot(page, "web_cracks_result_1366x768", full_page=True)

    # a bi-layer texture of the same photo, k = 8 noises at most
    page.goto(f"{server}exemplars/{result['exemplar_id']}")
    page.get_by_test_id("param-kind").select_option("bilayer")
    assert not page.get_by_test_id("param-k").is_disabled()
    page.get_by_test_id("param-k").fill("9")
    page.get_by_test_id("param-size").select_option("256x256")
    page.get_by_test_id("generate").click()
    assert "2 to 8" in page.get_by_test_id("generate-error").text_content()
    page.get_by_test_id("param-k").fill("2")
    page.get_by_test_id("generate").click()
    _follow_job(page)
    bilayer_id = re.search(r"/results/(\d+)", page.url).group(1)
    bilayer = page.request.get(f"{server}api/results/{bilayer_id}").json()
    assert bilayer["params"]["model"] == "bilayer" and bilayer["params"]["size"] == [256, 256]

    # a flat photo: no cracks to grow, and the page says why
    flat = tmp_path / "flat.png"
    from barkgen.io import write_png

    write_png(flat, np.full((128, 128, 3), 120, np.uint8))
    _upload(page, server, flat, "flat grey")
    page.wait_for_selector("[data-testid=param-kind][data-kinds='1']", timeout=60_000)
    assert page.locator("[data-testid=param-kind] option[value=cracks]").is_disabled()
    assert "no crack network" in page.get_by_test_id("param-kind").get_attribute("title")
    assert not errors, errors
    page.close()


def test_photo_light_and_width_from_the_form_reach_the_set_and_come_back(server, browser):
    """Photo light and Width under More settings, with the options' own help: the width only
    with material maps, a negative one refused on the page; Photo light at 40 % and a 0.8 m
    set make a 96² result whose params, report.json and NAME.json say so, its label map made
    with that light (not the page's, made with all of it out, which stays as it was); "Generate
    another seed" opens the form with both again."""
    import json

    from test_web_relief import _trunk_photo

    page = browser.new_page(viewport={"width": 1366, "height": 768})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    photo = {"name": "lit.png", "mimeType": "image/png", "buffer": _trunk_photo()}
    exemplar = page.request.post(f"{server}api/exemplars", multipart={"file": photo, "name": "lit form"}).json()
    page.goto(f"{server}exemplars/{exemplar['id']}")
    page.wait_for_function(  # the page's label map (k = 3, all of the light out), made and cached
        "() => { const i = document.querySelector('[data-testid=labels-in]');"
        " return i && i.complete && i.naturalWidth > 0; }",
        timeout=60_000,
    )
    page_labels = page.request.get(f"{server}api/exemplars/{exemplar['id']}/labels.png?k=3").body()
    fields = {f["name"]: f for f in page.request.get(f"{server}api/options").json()["fields"]}
    light, width = page.get_by_test_id("param-equalize-light"), page.get_by_test_id("param-width-m")
    page.get_by_test_id("more-settings").locator(":scope > summary").click()
    assert light.input_value() == "100" and page.get_by_test_id("equalize-light-value").text_content() == "100 % out"
    assert light.get_attribute("title") == fields["equalize_light"]["help"]
    assert width.get_attribute("title") == fields["width_m"]["help"]
    assert light.is_enabled() and width.is_enabled() and width.input_value() == ""  # material on by default
    page.get_by_test_id("param-material").uncheck()
    assert light.is_enabled() and width.is_disabled()  # the width only with material maps
    assert width.get_attribute("placeholder") == "0.5 (assumed)"
    page.get_by_test_id("param-size").select_option("custom")
    page.get_by_test_id("param-width").fill("96")
    page.get_by_test_id("param-height").fill("96")
    page.get_by_test_id("param-material").check()
    assert width.is_enabled()
    width.fill("-1")
    page.get_by_test_id("generate").click()
    assert "metres from 0.001" in page.get_by_test_id("generate-error").text_content()
    assert "job=" not in page.url
    light.evaluate("el => { el.value = 40; el.dispatchEvent(new Event('input', {bubbles: true})); }")
    assert page.get_by_test_id("equalize-light-value").text_content() == "40 % out"
    width.fill("0.8")
    page.get_by_test_id("param-seed").fill("7")
    page.get_by_test_id("generate").click()
    _follow_job(page, timeout_s=120)
    result_id = re.search(r"/results/(\d+)", page.url).group(1)
    result = page.request.get(f"{server}api/results/{result_id}").json()
    assert result["params"]["equalize_light"] == 0.4 and result["params"]["width_m"] == 0.8

    def file(name: str) -> bytes:
        return page.request.get(f"{server}{result['files'][name].lstrip('/')}").body()

    assert json.loads(file("report.json"))["light_equalization"] == 0.4
    set_name = next(n for n in result["files"] if n.endswith("_Displacement.png"))[: -len("_Displacement.png")]
    record = json.loads(file(f"{set_name}.json"))
    assert abs(record["width_m"] - 0.8) < 1e-6 and record["light_equalization"] == 0.4
    # the job's label map is its own, less of the light out; the page's is kept as it was
    assert page.request.get(f"{server}{result['labels_in_url'].lstrip('/')}").body() != page_labels
    assert page.request.get(f"{server}api/exemplars/{exemplar['id']}/labels.png?k=3").body() == page_labels
    # "Generate another seed": the form again with this result's photo light and width
    page.get_by_test_id("another-seed").click()
    page.wait_for_url(re.compile(r"/exemplars/\d+\?"))
    page.wait_for_function("() => document.querySelector('[data-testid=equalize-light-value]').textContent")
    assert light.input_value() == "40" and width.input_value() == "0.8" and width.is_enabled()
    assert page.get_by_test_id("equalize-light-value").text_content() == "40 % out"
    assert not errors, errors
    page.close()


def test_painter_over_the_bark_with_undo_redo_and_fill(server, browser):
    """The label painter shows the result's bark under the labels; a stroke, undone and redone
    (buttons and Ctrl+Z), and a fill of one region with another label."""
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.get_by_test_id("param-size").select_option("256x256")
    page.get_by_test_id("param-tile").check()
    page.get_by_test_id("param-seed").fill("4")
    # texton labels (the label map on the page follows) and the label-only engine's shapes
    page.get_by_test_id("more-settings").locator(":scope > summary").click()
    page.get_by_test_id("param-method").select_option("texton")
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=labels-in]');"
        " return i && /method=texton/.test(i.src) && i.complete && i.naturalWidth > 0; }",
        timeout=60_000,
    )
    page.get_by_test_id("param-strategy").select_option("engine")
    page.get_by_test_id("generate").click()
    _follow_job(page)
    result_id = re.search(r"/results/(\d+)", page.url).group(1)
    params = page.request.get(f"{server}api/results/{result_id}").json()["params"]
    assert params["method"] == "texton" and params["strategy"] == "engine"
    canvas = page.get_by_test_id("paint-canvas")
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=paint-bark]');"
        " return i && i.complete && i.naturalWidth === 256; }",
        timeout=30_000,
    )
    page.wait_for_function("() => document.querySelector('[data-testid=paint-canvas]').width > 0")
    assert float(canvas.evaluate("c => getComputedStyle(c).opacity")) < 1  # the bark shows through
    canvas.scroll_into_view_if_needed()
    pristine = canvas.evaluate("c => c.toDataURL()")
    assert page.get_by_test_id("paint-undo").is_disabled()
    page.get_by_test_id("paint-swatch").first.click()
    box = canvas.bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.2, box["y"] + box["height"] * 0.5)
    page.mouse.down()
    for step in range(1, 11):
        page.mouse.move(box["x"] + box["width"] * (0.2 + 0.05 * step), box["y"] + box["height"] * 0.5)
    page.mouse.up()
    painted = canvas.evaluate("c => c.toDataURL()")
    assert painted != pristine
    page.get_by_test_id("paint-undo").click()
    assert canvas.evaluate("c => c.toDataURL()") == pristine
    page.get_by_test_id("paint-redo").click()
    assert canvas.evaluate("c => c.toDataURL()") == painted
    page.mouse.move(box["x"] + 5, box["y"] + 5)
    page.keyboard.press("Control+z")
    assert canvas.evaluate("c => c.toDataURL()") == pristine
    # fill: the region under a point takes the chosen label, wholly
    # (the region is 4-connected: the pixels of the corner's label next to the corner change too)
    same_as_corner = """c => { const d = c.getContext('2d').getImageData(0, 0, 2, 1).data;
        return d[0] === d[4] && d[1] === d[5] && d[2] === d[6]; }"""
    neighbour_same = canvas.evaluate(same_as_corner)
    corner = canvas.evaluate("c => Array.from(c.getContext('2d').getImageData(0, 0, 1, 1).data.slice(0, 3))")
    swatches = page.get_by_test_id("paint-swatch")
    corner_css = f"rgb({corner[0]}, {corner[1]}, {corner[2]})"
    last = next(  # a label other than the corner's own
        swatches.nth(i)
        for i in range(swatches.count())
        if swatches.nth(i).evaluate("b => getComputedStyle(b).backgroundColor") != corner_css
    )
    last.click()
    page.get_by_test_id("paint-tool-fill").click()
    page.mouse.click(box["x"] + 1, box["y"] + 1)
    filled = canvas.evaluate("c => c.toDataURL()")
    assert filled != pristine
    top_left = canvas.evaluate("c => Array.from(c.getContext('2d').getImageData(0, 0, 1, 1).data.slice(0, 3))")
    swatch = last.evaluate("b => getComputedStyle(b).backgroundColor")
    assert swatch == f"rgb({top_left[0]}, {top_left[1]}, {top_left[2]})"
    if neighbour_same:  # the pixel right of the corner was in its region: filled with it
        assert canvas.evaluate(same_as_corner)
    _shot(page, "web_painter_1366x768", full_page=True)
    page.close()


def test_the_form_builds_its_fields_from_the_options_the_server_offers(server, browser):
    """The form's fields come from ``/api/options``: an option the page has no control of its
    own for (a new one: here added to the server's answer) gets one built from its declaration,
    in its group's section, with its range and help; a changed value goes into the job request,
    an unchanged one is left to the server's default, one out of range is refused in one line."""
    page = browser.new_page()
    dummy = {
        "name": "dummy_strength",
        "kind": "float",
        "default": 0.5,
        "minimum": 0,
        "maximum": 2,
        "choices": None,
        "help": "A test's option.",
        "group": "advanced",
        "needs": None,
    }

    def add_dummy(route):
        answer = route.fetch().json()
        answer["fields"].append(dummy)
        route.fulfill(json=answer)

    sent = []

    def capture(route):
        if route.request.method != "POST":
            route.continue_()
            return
        sent.append(route.request.post_data_json)
        route.fulfill(status=400, json={"detail": "captured by the test"})

    page.route("**/api/options", add_dummy)
    page.route("**/api/jobs", capture)
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.wait_for_selector("[data-testid=param-kind][data-kinds='1']", timeout=60_000)
    page.get_by_test_id("more-settings").locator(":scope > summary").click()
    page.get_by_test_id("advanced-settings").locator(":scope > summary").click()
    control = page.get_by_test_id("param-dummy-strength")
    assert control.is_visible() and control.get_attribute("title") == "A test's option."
    assert (control.get_attribute("min"), control.get_attribute("max"), control.input_value()) == ("0", "2", "0.5")
    # the page's own controls stay as they were; the web options without one are built
    for testid in ("param-relief", "param-equalize-light", "param-width-m", "param-method", "param-strategy"):
        assert page.get_by_test_id(testid).get_attribute("data-option") is None, testid
    for testid in ("param-rotations", "param-label-weight", "param-blend", "param-light"):
        assert page.get_by_test_id(testid).get_attribute("data-option") == "built", testid
    page.get_by_test_id("param-material").uncheck()  # (on by default)
    assert page.get_by_test_id("param-light").is_disabled()  # it needs the material maps
    control.fill("1.25")
    page.get_by_test_id("generate").click()
    page.get_by_test_id("generate-error").wait_for()
    body = sent[-1]
    assert body["dummy_strength"] == 1.25 and "label_weight" not in body and "rotations" not in body
    assert body["method"] == "color" and body["structure"] == "labels" and "relief" not in body
    control.fill("3")
    page.get_by_test_id("generate").click()
    assert "Dummy strength must be a number (0 to 2)" in page.get_by_test_id("generate-error").text_content()
    assert len(sent) == 1
    page.close()


@pytest.mark.parametrize("width, height", [(1366, 768), (390, 844)])
def test_pages_fit_a_laptop_and_a_phone_and_a_missing_result_says_so(server, browser, width, height):
    """At 1366 x 768 and on a phone the pages need no sideways scrolling and the Generate button
    can be reached; a result that does not exist says so and offers no download."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.wait_for_selector("[data-testid=param-kind][data-kinds='1']", timeout=60_000)
    assert page.evaluate("() => document.documentElement.scrollWidth <= window.innerWidth")
    _shot(page, f"web_exemplar_{width}x{height}")
    button = page.get_by_test_id("generate")
    button.scroll_into_view_if_needed()
    assert button.is_visible()
    top, bottom = button.evaluate("b => { const r = b.getBoundingClientRect(); return [r.top, r.bottom]; }")
    assert 0 <= top and bottom <= height, (top, bottom)
    page.goto(f"{server}results/999999")
    page.get_by_test_id("page-error").wait_for()
    assert "does not exist" in page.get_by_test_id("page-error").text_content()
    assert not page.get_by_test_id("download").is_visible()
    page.close()


def _relief_heights(page, server: str, result_id: str, edits: list) -> np.ndarray:
    answer = page.request.post(f"{server}api/results/{result_id}/relief", data={"edits": edits})
    assert answer.ok, answer.text()
    width, rows = (int(v) for v in answer.headers["x-height-size"].split("x"))
    return np.frombuffer(answer.body(), "<f4").reshape(rows, width)


def _set_heights(page, server: str, result: dict) -> np.ndarray:
    """A result's height in px from its 16-bit displacement and its record's depth and midlevel."""
    import json

    from barkgen.io import decode_image

    name = next(n for n in result["files"] if n.endswith("_Displacement.png"))[: -len("_Displacement.png")]
    meta = json.loads(page.request.get(f"{server}{result['files'][name + '.json'][1:]}").body())
    levels = decode_image(page.request.get(f"{server}{result['files'][name + '_Displacement.png'][1:]}").body())
    levels = (levels[..., 0] if levels.ndim == 3 else levels).astype(np.float64) / 65535.0
    return (levels - meta["displacement_midlevel"]) * meta["displacement_depth_px"]


def test_relief_editor_stroke_spreads_relights_the_trunk_and_saves(server, browser):
    """wang2003 Fig. 6 in the page: on a 1024² result, a stroke of five edits raises the bark
    under it and at the self-similar places (the server's answer, checked against the edits the
    page made), the trunk relights, undo and redo; Depth and Photo light re-render the trunk at
    once with no request; Save makes a result whose displacement rose where the page showed it
    and stayed where it did not, twice as deep, with half of the photo's light out of its
    colour. Each edit's time (pointer to the relit trunk) is kept on the canvas;
    benchmarks/bench_relief_editor.py reports it."""
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url(re.compile(r"/exemplars/\d+"))
    page.get_by_test_id("param-size").select_option("1024x1024")
    page.get_by_test_id("param-tile").check()
    page.get_by_test_id("param-material").check()
    page.get_by_test_id("param-seed").fill("5")
    page.get_by_test_id("generate").click()
    _follow_job(page)
    result_id = re.search(r"/results/(\d+)", page.url).group(1)
    page.wait_for_selector("[data-testid=trunk-canvas][data-ready='1']", timeout=60_000)
    page.wait_for_selector("[data-testid=relief-canvas][data-ready='1']", state="attached", timeout=60_000)
    trunk_before = _canvas_pixels(page, "trunk-canvas")  # (scrolls to the trunk)
    canvas = page.get_by_test_id("relief-canvas")
    assert canvas.is_hidden() and page.get_by_test_id("result-texture").is_visible()
    page.get_by_test_id("relief-toggle").check()  # the editor takes the texture's place
    assert canvas.is_visible() and page.get_by_test_id("result-texture").is_hidden()
    page.get_by_test_id("relief-strength").fill("3")
    canvas.evaluate("c => c.scrollIntoView({block: 'center'})")
    box = canvas.bounding_box()
    scale = box["width"] / 1024.0
    # a stroke of five edits: 40 result px apart, left to right at one height
    points = [(200 + 40 * i, 300) for i in range(5)]
    page.mouse.move(box["x"] + points[0][0] * scale + 0.5 * scale, box["y"] + 300.5 * scale)
    page.mouse.down()
    for x, y in points[1:]:
        page.mouse.move(box["x"] + (x + 0.5) * scale, box["y"] + (y + 0.5) * scale)
    page.mouse.up()
    page.wait_for_function(
        "() => { const c = document.querySelector('[data-testid=relief-canvas]');"
        " return c.dataset.edits === '5' && JSON.parse(c.dataset.latencies || '[]').length === 5; }",
        timeout=30_000,
    )
    edits = page.evaluate(
        "() => fetch(document.querySelector('[data-testid=relief-download]').href).then(r => r.json())"
    )["edits"]
    assert [(e["x"], e["y"]) for e in edits] == [(x, y) for x, y in points]
    assert all(e["delta"] == 3 and e["radius"] == 4 for e in edits)
    base = _relief_heights(page, server, result_id, [])
    change = _relief_heights(page, server, result_id, edits) - base
    for x, y in points:
        assert change[y, x] >= 3.0 - 1e-3
    far = np.ones(change.shape, bool)
    far[300 - 40 : 300 + 41, 200 - 40 : 360 + 41] = False
    assert 0.005 < ((change > 0.1) & far).mean() < 0.9  # spread to self-similar places
    # the trunk was relit from the new relief
    relit = np.abs(_canvas_pixels(page, "trunk-canvas") - trunk_before).sum(axis=2)
    assert (relit > 12).mean() > 0.005, (relit > 12).mean()
    # undo takes the stroke back, redo brings it again
    page.get_by_test_id("relief-undo").click()
    page.wait_for_function("() => document.querySelector('[data-testid=relief-canvas]').dataset.edits === '0'")
    assert page.get_by_test_id("relief-undo").is_disabled()
    page.get_by_test_id("relief-redo").click()
    page.wait_for_function("() => document.querySelector('[data-testid=relief-canvas]').dataset.edits === '5'")
    # Depth 2x and Photo light 50 %: the trunk re-renders at once, on the page alone (no request)
    asked = []
    page.on("request", lambda request: asked.append(request.url))
    trunk_edited = _canvas_pixels(page, "trunk-canvas")
    took = {testid: _slide(page, testid, value) for testid, value in (("relief-depth", 1), ("photo-light", 50))}
    deeper = np.abs(_canvas_pixels(page, "trunk-canvas") - trunk_edited).sum(axis=2)
    assert (deeper > 12).mean() > 0.005, (deeper > 12).mean()
    assert page.get_by_test_id("relief-depth-value").text_content().startswith("2.00× · ")
    assert page.get_by_test_id("photo-light-value").text_content() == "50 %"
    assert not [url for url in asked if "/api/" in url], asked
    if SHOTS:  # the editor beside the trunk it relit, 2x as deep
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        page.locator(".result-layout").screenshot(path=str(Path(SHOTS) / "web_relief_1366x768.png"))
    page.wait_for_function("() => document.querySelector('[data-testid=relief-canvas]').dataset.lightPower === '0.5'")
    relit_ms = page.get_by_test_id("relief-canvas").get_attribute("data-relit")
    print(f"slider to trunk frame: {took} ms; texture relit in {relit_ms} ms")  # (pytest -s shows it)
    # Save: a new result, its displacement risen where the page showed it, twice as deep, half
    # of the photo's light out of its colour
    page.get_by_test_id("relief-save").click()
    _follow_job(page)
    saved_id = re.search(r"/results/(\d+)", page.url).group(1)
    assert saved_id != result_id
    saved = page.request.get(f"{server}api/results/{saved_id}").json()
    parent = page.request.get(f"{server}api/results/{result_id}").json()
    assert saved["params"]["relief_from"] == {
        "result_id": int(result_id),
        "edits": 5,
        "relief": 2.0,
        "light_equalization": 0.5,
    }
    assert saved["material"]["light_equalization"] == 0.5
    rise = _set_heights(page, server, saved) - 2 * _set_heights(page, server, parent)
    quantum = 2 * max(saved["displacement_depth_px"], 2 * parent["displacement_depth_px"]) / 65535
    assert np.abs(rise - 2 * change).max() < 2 * 0.02 + quantum
    assert not errors, errors


def _slide(page, testid: str, value: float) -> float:
    """Move a range input as a drag does (an ``input`` event) and wait for the trunk's next
    frame: the milliseconds from the event to the frame drawn."""
    return page.get_by_test_id(testid).evaluate(
        """async (input, value) => {
             const trunk = document.querySelector('[data-testid=trunk-canvas]');
             const before = Number(trunk.dataset.frames);
             const t0 = performance.now();
             input.value = String(value);
             input.dispatchEvent(new Event('input', {bubbles: true}));
             input.dispatchEvent(new Event('change', {bubbles: true}));
             while (Number(trunk.dataset.frames) === before) await new Promise((r) => requestAnimationFrame(r));
             return performance.now() - t0;
           }""",
        value,
    )


def test_photo_light_relights_the_trunk_and_the_texture_or_says_why_not(server, browser):
    """A 128² result of a photo lit as round a trunk: Photo light at 0 % puts the photo's broad
    light back, on the trunk and on the relief editor's texture at once (no job); a result with
    no record of its photo's light (its page's record as an older result's) has the slider off
    and one line saying why."""
    from test_web_relief import _trunk_photo

    page = browser.new_page(viewport={"width": 1366, "height": 768})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    photo = {"name": "lit.png", "mimeType": "image/png", "buffer": _trunk_photo()}
    exemplar = page.request.post(f"{server}api/exemplars", multipart={"file": photo, "name": "lit bark"}).json()
    settings = {"size": "128x128", "k": 2, "tile": True, "material": True, "seed": 3}
    job = page.request.post(f"{server}api/jobs", data={"exemplar_id": exemplar["id"], **settings}).json()
    deadline = time.monotonic() + 120
    while (state := page.request.get(f"{server}api/jobs/{job['id']}").json())["state"] not in ("done", "failed"):
        assert time.monotonic() < deadline, state
        time.sleep(0.2)
    assert state["state"] == "done", state
    result = page.request.get(f"{server}api/results/{state['result_id']}").json()
    jobs = len(page.request.get(f"{server}api/jobs").json())
    page.goto(f"{server}results/{result['id']}")
    page.wait_for_selector("[data-testid=trunk-canvas][data-ready='1']", timeout=60_000)
    page.wait_for_selector("[data-testid=relief-canvas][data-ready='1']", state="attached", timeout=60_000)
    light = page.get_by_test_id("photo-light")
    assert light.is_enabled() and light.input_value() == "100"
    assert page.get_by_test_id("photo-light-note").is_hidden()
    page.get_by_test_id("relief-toggle").check()
    trunk, texture = _canvas_pixels(page, "trunk-canvas"), _canvas_pixels(page, "relief-canvas")
    took = _slide(page, "photo-light", 0)
    page.wait_for_function("() => document.querySelector('[data-testid=relief-canvas]').dataset.lightPower === '1'")
    relit_trunk = np.abs(_canvas_pixels(page, "trunk-canvas") - trunk).sum(axis=2)
    relit_texture = np.abs(_canvas_pixels(page, "relief-canvas") - texture).sum(axis=2)
    assert (relit_trunk > 12).mean() > 0.05 and (relit_texture > 12).mean() > 0.05
    assert len(page.request.get(f"{server}api/jobs").json()) == jobs  # no job made
    print(f"photo light to frame: {took:.0f} ms")
    # a result made before barkgen kept the photo's light: the slider off, and why
    older = {**result, "material": {**result["material"], "illumination_url": None}}
    page.route(f"**/api/results/{result['id']}", lambda route: route.fulfill(json=older))
    page.goto(f"{server}results/{result['id']}")
    page.wait_for_selector("[data-testid=trunk-canvas][data-ready='1']", timeout=60_000)
    assert page.get_by_test_id("photo-light").is_disabled()
    note = page.get_by_test_id("photo-light-note")
    assert note.is_visible() and "no record of its photo's light" in note.text_content()
    assert page.get_by_test_id("relief-depth").is_enabled()
    assert not errors, errors
    page.close()
