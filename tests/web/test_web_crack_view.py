"""The crack view in a real browser (Debian's Chromium via Playwright, as test_web_browser.py):
a photo of dried mud, kind "cracks": its crack network drawn over the photo; a branch deleted
by clicking it, one extended, a furcation added, Undo and Reset; a cracks job sent the edited
network; then Rectify by four clicks opens the rectified photo as a new exemplar
(sibbing2010 §6, Fig. 8)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import crack_photo_file
from test_web_browser import _follow_job, _shot, _upload, browser, server  # noqa: F401 (fixtures)

from barkgen.branching import Structure, add_furcation, delete_branch, extend_branch, nearest_branch


def _isolated_vertex(structure: Structure, index: int, clear: float = 6.0, *, end: bool = False):
    """A vertex of branch ``index`` (its last one with ``end``) at least ``clear`` px from every
    other branch, or None."""
    b = structure.branches[index]
    candidates = [len(b.points) - 1] if end else range(len(b.points) // 4, 3 * len(b.points) // 4)
    others = Structure(structure.step, structure.size, [o for j, o in enumerate(structure.branches) if j != index])
    for v in candidates:
        p = b.xy[v]
        if 8 < p[0] < structure.width - 8 and 8 < p[1] < structure.height - 8 and nearest_branch(others, p)[1] > clear:
            return [float(p[0]), float(p[1])]
    return None


def _pick(structure: Structure, *, end: bool = False) -> tuple[int, list[float]]:
    for i in range(len(structure.branches)):
        p = _isolated_vertex(structure, i, end=end)
        if p is not None:
            return i, p
    pytest.fail("no branch with a vertex clear of the others")


def _click_photo(page, x: float, y: float, size) -> None:
    """Click the photo's pixel (x, y) in the crack view."""
    svg = page.get_by_test_id("crack-svg")
    svg.scroll_into_view_if_needed()
    box = svg.bounding_box()
    sx, sy = box["x"] + x / size[0] * box["width"], box["y"] + y / size[1] * box["height"]
    assert 0 <= sy < page.viewport_size["height"], (sy, box)
    page.mouse.click(sx, sy)


def _wait_edits(page, count: int) -> int:
    """Wait for the view to have ``count`` edits; its number of branches."""
    view = page.locator(f"[data-testid=crack-view][data-edits='{count}']")
    view.wait_for(timeout=20_000)
    return int(view.get_attribute("data-branches"))


def _tool(page, name: str) -> None:
    """Choose a tool (a click on a chosen one puts it down)."""
    button = page.get_by_test_id(f"crack-tool-{name}")
    if button.get_attribute("aria-pressed") != "true":
        button.click()
    assert button.get_attribute("aria-pressed") == "true"


def _polyline(page, index: int) -> np.ndarray:
    text = page.locator(f"[data-testid=crack-branch][data-index='{index}']").get_attribute("points")
    return np.array([[float(v) for v in p.split(",")] for p in text.split()])


def test_crack_view_delete_extend_furcation_undo_reset_job_and_rectify(server, browser):  # noqa: F811
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    _upload(page, server, crack_photo_file(256, 0, cell=32), "Dried mud", "CC0")
    exemplar = int(re.search(r"/exemplars/(\d+)", page.url).group(1))
    page.wait_for_selector("[data-testid=param-kind][data-kinds='1']", timeout=60_000)
    assert page.get_by_test_id("crack-view").is_hidden()
    page.get_by_test_id("param-kind").select_option("cracks")
    page.wait_for_selector("[data-testid=crack-view][data-loaded='1']", timeout=60_000)
    assert page.get_by_test_id("labels-figure").is_hidden() and page.get_by_test_id("photo-figure").is_hidden()
    source = Structure.from_dict(page.request.get(f"{server}api/exemplars/{exemplar}/cracks").json())
    size = source.size
    n0 = len(source.branches)
    assert page.locator("[data-testid=crack-branch]").count() == n0
    assert page.get_by_test_id("crack-count").text_content() == str(n0)
    assert page.get_by_test_id("crack-undo").is_disabled()

    # Delete: click a branch; it goes with its sub-branches (as barkgen.branching.delete_branch)
    index, at = _pick(source)
    _tool(page, "delete")
    _click_photo(page, *at, size)
    deleted = delete_branch(source, index)
    assert _wait_edits(page, 1) == len(deleted.branches) < n0

    # Extend: click near a free end, then a target beyond it; the branch reaches the target
    index, end = _pick(deleted, end=True)
    xy = deleted.branches[index].xy
    ahead = xy[-1] + 14 * (xy[-1] - xy[-4]) / np.hypot(*(xy[-1] - xy[-4]))
    target = np.clip(ahead, 4, np.array(size) - 4).round(1).tolist()
    _tool(page, "extend")
    _click_photo(page, *end, size)
    assert page.locator("[data-testid=crack-mark]").count() == 1  # the first click is marked
    _click_photo(page, *target, size)
    assert _wait_edits(page, 2) == len(deleted.branches)
    line = _polyline(page, index)
    _last_extend = (index, target)
    expected = extend_branch(deleted, index, target)
    assert len(line) == pytest.approx(len(expected.branches[index].points), abs=1)
    assert np.hypot(*(line[-1] - target)) < 1.5 and np.allclose(line[: len(xy)], xy, atol=1e-3)

    # Furcation: click on a branch, then where the new branch ends: a new last branch on it
    index, at = _pick(deleted)
    to = np.clip(np.array(at) + [18, -18], 4, np.array(size) - 4).tolist()
    _tool(page, "furcation")
    _click_photo(page, *at, size)
    _click_photo(page, *to, size)
    n3 = _wait_edits(page, 3)
    assert n3 == len(deleted.branches) + 1
    child = _polyline(page, n3 - 1)
    parent = deleted.branches[index].xy
    assert np.hypot(*(parent - child[0]).T).min() < 1e-3  # it starts on a vertex of its parent
    assert np.hypot(*(child[-1] - to)) < 1.5
    assert len(add_furcation(deleted, index, at, to).branches) == n3
    assert "added on branch" in page.get_by_test_id("crack-status").text_content()
    _shot(page, "web_crack_view_1366x768")

    # a click far from any branch: one line, the network unchanged
    current = add_furcation(extend_branch(deleted, *_last_extend), index, at, to)
    far = next(
        (
            (x, y)
            for y in range(8, size[1] - 8, 2)
            for x in range(8, size[0] - 8, 2)
            if nearest_branch(current, (x, y))[1] > 9
        ),
        None,
    )
    if far is not None:  # (a network as dense as to leave no such place is not tested here)
        _tool(page, "delete")
        _click_photo(page, *far, size)
        page.get_by_test_id("crack-error").wait_for()
        assert "no branch within" in page.get_by_test_id("crack-error").text_content()
        assert page.get_by_test_id("crack-view").get_attribute("data-edits") == "3"

    # Undo, then Reset: back to the photo's own network
    page.get_by_test_id("crack-undo").click()
    assert _wait_edits(page, 2) == len(deleted.branches)
    page.get_by_test_id("crack-reset").click()
    assert _wait_edits(page, 0) == n0 and page.get_by_test_id("crack-reset").is_disabled()

    # delete again and generate: the job is sent the edited network and learns from it
    index, at = _pick(source)
    _tool(page, "delete")
    _click_photo(page, *at, size)
    edited = _wait_edits(page, 1)
    page.get_by_test_id("param-size").select_option("custom")
    page.get_by_test_id("param-width").fill("96")
    page.get_by_test_id("param-height").fill("80")
    page.get_by_test_id("param-seed").fill("3")
    page.get_by_test_id("generate").click()
    _follow_job(page)
    result_id = int(re.search(r"/results/(\d+)", page.url).group(1))
    params = page.request.get(f"{server}api/results/{result_id}").json()["params"]
    assert params["structure"] == "cracks" and params["seed"] == 3
    assert params["crack_structure"] == {"edited": True, "branches": edited}
    report = page.request.get(f"{server}api/results/{result_id}/files/report.json").json()
    assert report["crack_model"]["branches"] == edited
    page.get_by_test_id("result-params").wait_for()
    assert "edited cracks" in page.get_by_test_id("result-params").text_content()

    # Rectify: four clicks; the rectified photo is a new exemplar and the page moves to it
    page.goto(f"{server}exemplars/{exemplar}?kind=cracks")
    page.wait_for_selector("[data-testid=crack-view][data-loaded='1']", timeout=60_000)
    _tool(page, "rectify")
    corners = [[20, 30], [230, 14], [244, 240], [12, 222]]
    for corner in corners[:3]:
        _click_photo(page, *corner, size)
    assert page.locator("[data-testid=crack-mark]").count() == 3
    with page.expect_navigation():
        _click_photo(page, *corners[3], size)
    page.wait_for_url(re.compile(r"/exemplars/\d+\?kind=cracks"))
    new_id = int(re.search(r"/exemplars/(\d+)", page.url).group(1))
    assert new_id != exemplar
    record = page.request.get(f"{server}api/exemplars/{new_id}").json()
    assert record["name"] == "Dried mud (rectified)" and record["source"] == "rectified from Dried mud"
    assert record["licence"] == "CC0" and abs(record["width"] - 221) <= 4 and abs(record["height"] - 209) <= 4
    page.wait_for_selector("[data-testid=crack-view][data-loaded='1']", timeout=60_000)
    assert int(page.get_by_test_id("crack-view").get_attribute("data-branches")) > 10
    # bad corners are answered in one line, on the page
    _tool(page, "rectify")
    for corner in ([20, 20], [200, 200], [200, 20], [20, 200]):  # a bow tie
        _click_photo(page, *corner, (record["width"], record["height"]))
    page.get_by_test_id("crack-error").wait_for()
    assert "convex" in page.get_by_test_id("crack-error").text_content()
    assert not errors, errors
    page.close()
