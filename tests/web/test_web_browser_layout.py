"""The web app without surprise, in a real browser (issue 66): a set's zip uploaded beside the
photo of its colour is an entry of its own, the Generate button is in the first screen at
1366x768 and 390x844, a 1024x512 result's thumbnail is shown whole (2:1, not cropped square),
and the form left as it is asks for ``barkgen generate``'s own options (but for the
differences ``WEB_DEFAULTS`` names).

Debian's Chromium driven by Playwright against ``barkgen serve`` (as in test_web_browser.py;
skipped without /usr/bin/chromium). Screenshots go to ``$BARKGEN_SHOTS`` when it is set."""

from __future__ import annotations

import io
import json
import re
import zipfile

import numpy as np
import pytest
from test_web_api import _set_zip
from test_web_browser import _shot, browser, server  # noqa: F401 - the fixtures

SCREENS = {"1366x768": (1366, 768), "390x844": (390, 844)}


def _exemplar_page(browser, server: str, size: tuple[int, int], exemplar_id: int = 1):  # noqa: F811
    page = browser.new_page(viewport={"width": size[0], "height": size[1]})
    page.goto(f"{server}exemplars/{exemplar_id}")
    # the form has its defaults once /api/options is read (the width is filled from them)
    page.wait_for_function("() => document.querySelector('[data-testid=param-width]').value !== ''")
    page.wait_for_function(
        "() => { const i = document.querySelector('[data-testid=labels-in]');"
        " return i && i.complete && i.naturalWidth > 0; }",
        timeout=60_000,
    )
    return page


def _longest_run(flags: np.ndarray) -> int:
    """The length of the longest run of true values (the picture's rows or columns, apart from
    the card's 1 px border the element's screenshot may catch)."""
    best = run = 0
    for flag in flags:
        run = run + 1 if flag else 0
        best = max(best, run)
    return best


@pytest.mark.parametrize("screen", SCREENS)
def test_the_generate_button_is_in_the_first_screen(server, browser, screen):  # noqa: F811
    width, height = SCREENS[screen]
    page = _exemplar_page(browser, server, (width, height))
    try:
        box = page.get_by_test_id("generate").bounding_box()
        assert box is not None
        assert box["y"] >= 0 and box["y"] + box["height"] <= height, (screen, box)
        assert box["x"] >= 0 and box["x"] + box["width"] <= width, (screen, box)
        # nothing lies over it: the point at its middle is the button
        hit = page.evaluate(
            "([x, y]) => document.elementFromPoint(x, y)?.closest('[data-testid=generate]') !== null",
            [box["x"] + box["width"] / 2, box["y"] + box["height"] / 2],
        )
        assert hit, (screen, box)
        _shot(page, f"web_exemplar_{screen}")
    finally:
        page.close()


def test_the_forms_defaults_are_the_clis(server, browser):  # noqa: F811
    """Generate on the untouched form: the options the server makes of its request are
    GenerateOptions' own (``barkgen generate``'s) for every field but the seed (a random one)
    and material (on, as the quickstart makes it): exactly ``WEB_DEFAULTS``' differences."""
    from barkgen._shared.options import option_fields
    from barkgen.pipeline import GenerateOptions
    from barkgen.web.routes_jobs import WEB_DEFAULTS, JobRequest, request_options

    page = _exemplar_page(browser, server, SCREENS["1366x768"])
    sent = []

    def intercept(route):
        sent.append(json.loads(route.request.post_data))
        route.fulfill(status=400, content_type="application/json", body='{"detail": "(the test keeps the job)"}')

    try:
        page.route("**/api/jobs", intercept)
        page.get_by_test_id("generate").click()
        page.get_by_test_id("generate-error").wait_for()
    finally:
        page.close()
    assert len(sent) == 1, sent
    body = sent[0]
    assert body.get("preset", "ambientcg") == "ambientcg"
    asked = request_options(JobRequest(**body))
    cli = {f.name: f.default for f in option_fields(GenerateOptions, "web")}
    differ = {name for name in cli if asked[name] != cli[name]}
    assert differ <= set(WEB_DEFAULTS), {name: (asked[name], cli[name]) for name in differ}
    assert asked["material"] is True and cli["material"] is False  # the one named difference
    assert isinstance(asked["seed"], int)  # a random one, the page's


def test_a_sets_zip_is_a_new_entry_beside_the_photo_of_its_colour(server, browser, tmp_path):  # noqa: F811
    data, _ = _set_zip()
    colour = tmp_path / "colour.png"
    colour.write_bytes(zipfile.ZipFile(io.BytesIO(data)).read("Bark099_1K-PNG/Bark099_1K-PNG_Color.png"))
    archive = tmp_path / "Bark099_1K-PNG.zip"
    archive.write_bytes(data)
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    try:
        ids = []
        for path, name in ((colour, "the colour as a photo"), (archive, "")):
            page.goto(server)
            page.get_by_test_id("exemplar-card").first.wait_for()
            page.get_by_test_id("upload-file").set_input_files(str(path))
            if name:
                page.get_by_test_id("upload-name").fill(name)
            page.get_by_test_id("upload-submit").click()
            page.wait_for_url(re.compile(r"/exemplars/\d+"))
            ids.append(int(re.search(r"/exemplars/(\d+)", page.url).group(1)))
            page.get_by_test_id("exemplar-name").filter(has_not_text="Bark photo").wait_for()
            assert "existing" not in page.url
            assert not page.get_by_test_id("exemplar-notice").is_visible()  # nothing was there already
        assert ids[0] != ids[1]
        assert page.get_by_test_id("exemplar-name").text_content() == "Bark099"
        _shot(page, "web_set_entry_1366x768")
        entries = {e["id"]: e for e in page.request.get(f"{server}api/exemplars").json()}
        assert entries[ids[0]]["name"] == "the colour as a photo" and entries[ids[0]]["maps"] == []
        assert entries[ids[1]]["maps"] == ["normal_gl", "roughness"]
    finally:
        page.close()


def test_a_1024x512_results_thumbnail_is_whole(server, browser):  # noqa: F811
    """The card of a 1024x512 result shows its whole thumbnail: the picture drawn 2:1 (within
    1 px), the card's dark ground above and below it."""
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    try:
        body = {"exemplar_id": 1, "size": "1024x512", "k": 2, "tile": False, "material": False, "seed": 1}
        job = page.request.post(f"{server}api/jobs", data=body).json()["id"]
        for _ in range(600):
            state = page.request.get(f"{server}api/jobs/{job}").json()
            if state["state"] in ("done", "failed", "cancelled"):
                break
            page.wait_for_timeout(500)
        assert state["state"] == "done", state
        page.goto(f"{server}exemplars/1")
        card = page.locator(f"[data-testid=result-card][data-id='{state['result_id']}'] img")
        card.scroll_into_view_if_needed()
        page.wait_for_function(
            "(id) => { const i = document.querySelector(`[data-testid=result-card][data-id='${id}'] img`);"
            " return i && i.complete && i.naturalWidth > 0; }",
            arg=state["result_id"],
        )
        natural = card.evaluate("i => [i.naturalWidth, i.naturalHeight]")
        assert natural == [320, 160]
        from PIL import Image

        shown = np.asarray(Image.open(io.BytesIO(card.screenshot())).convert("RGB"), dtype=np.int16)
        h, w = shown.shape[:2]
        # the picture: what is not the card's dark ground, measured off its rounded corners
        picture = np.abs(shown - np.array([0x0E, 0x0F, 0x10])).max(axis=2) > 12
        drawn_h = _longest_run(picture[:, w // 4 : 3 * w // 4].mean(axis=1) > 0.5)
        drawn_w = _longest_run(picture[h // 3 : 2 * h // 3].mean(axis=0) > 0.5)
        assert drawn_w >= w - 4, (drawn_w, shown.shape)  # as wide as the card
        assert abs(drawn_w / drawn_h - 2.0) <= 2.0 / drawn_h + 0.02, (drawn_w, drawn_h)
        print(f"thumbnail of 1024x512 drawn {drawn_w}x{drawn_h} px in a {w}x{h} card: aspect {drawn_w / drawn_h:.3f}")
        _shot(page, "web_thumbnails_1366x768", full_page=True)
    finally:
        page.close()
