"""mimika studio in the browser: layout from 800×600 to 1920×1080 (no horizontal scroll, no
control off-screen, no overlaps, no jump after load), keyboard access (skip links, tabs, the
viewer, visible focus) and axe-core with no serious or critical violations."""

from __future__ import annotations

import itertools

import pytest

from studio_helpers import AXE

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]

#: controls a user needs at every size: inside the window, not zero-sized
CONTROLS = ["#project-name", "#btn-save", "#project-list", "#btn-load", "#btn-new", "#btn-import",
            "#btn-undo", "#btn-redo", "#export-menu summary", "#head-select", "#au-groups",
            "#btn-reset", "#view", "#view-tools", "#look-select", "#tab-expr", "#tab-blend",
            "#tab-latent", "#expr-filter", "#expr-list", "#expr-name", "#btn-expr-save",
            "#speech-text", "#text-count", "#lang", "#btn-speak", "#btn-recording",
            "#layers-menu summary",
            "#btn-play", "#btn-stop", "#tl-scroll", "#param-body", "#zoom-in",
            "#zoom-out", ".tl-head button"]  # (the ruler scrolls inside #tl-scroll)
#: regions that must not overlap each other
REGIONS = ["#left", "#viewport", "#right", "#bottom", "#topbar"]

GEOMETRY = """(sel) => [...document.querySelectorAll(sel)].map(e => {
  const r = e.getBoundingClientRect();
  return {sel, x: r.left, y: r.top, r: r.right, b: r.bottom, w: r.width, h: r.height};
})"""


def boxes(pg, sel: str) -> list[dict]:
    return pg.evaluate(GEOMETRY, sel)


def overlap(a: dict, b: dict, tol: float = 0.5) -> bool:
    return (min(a["r"], b["r"]) - max(a["x"], b["x"]) > tol
            and min(a["b"], b["b"]) - max(a["y"], b["y"]) > tol)


def check_layout(pg, width: int, height: int) -> None:
    assert pg.evaluate("document.documentElement.scrollWidth") <= width
    assert pg.evaluate("document.documentElement.scrollHeight") <= height
    for sel in CONTROLS:
        for b in boxes(pg, sel):
            assert b["w"] > 0 and b["h"] > 0, f"{sel} is not shown at {width}×{height}"
            assert b["x"] >= -0.5 and b["r"] <= width + 0.5, f"{sel} off-screen: {b}"
            assert b["y"] >= -0.5 and b["b"] <= height + 0.5, f"{sel} off-screen: {b}"
    regions = [boxes(pg, s)[0] for s in REGIONS]
    groups = boxes(pg, "#topbar > .group, #topbar > details")
    for a, b in itertools.combinations(regions, 2):
        assert not overlap(a, b), (a, b)
    for a, b in itertools.combinations(groups, 2):
        assert not overlap(a, b), (a, b)
    for head in pg.locator(".tl-head").all():
        label, button = head.locator("span").bounding_box(), head.locator("button")
        if button.count():
            bb = button.bounding_box()
            assert label["x"] + label["width"] <= bb["x"] + 0.5, "track name under its + button"
    assert boxes(pg, "#expr-list")[0]["h"] >= 80  # the library list stays usable
    assert boxes(pg, "#view")[0]["w"] >= 250


@pytest.mark.parametrize("size", [(800, 600), (1024, 768), (1920, 1080)],
                         ids=["800x600", "1024x768", "1920x1080"])
def test_layout_fits_the_window(open_studio, size):
    pg = open_studio(*size)
    check_layout(pg, *size)
    pg.click("#export-menu summary")  # an open menu stays inside the window too
    pg.wait_for_function("document.querySelector('#export-menu .menu-body')"
                         ".getBoundingClientRect().right <= innerWidth")
    for b in boxes(pg, "#export-menu .menu-body button"):
        assert b["r"] <= size[0] + 0.5 and b["b"] <= size[1] + 0.5, b
    pg.keyboard.press("Escape")
    pg.click("#tab-blend")
    assert boxes(pg, "#rules")[0]["h"] >= 60


SHIFTS = """window.__shifts = [];
new PerformanceObserver((list) => {
  for (const e of list.getEntries()) if (!e.hadRecentInput) window.__shifts.push(
    {value: e.value, t: e.startTime});
}).observe({type: "layout-shift", buffered: true});"""


def test_no_layout_jump_after_load(open_studio):
    """Bug: the page jumped about a second after load when the latent panel appeared."""
    pg = open_studio(1280, 800, init_script=SHIFTS)
    pg.wait_for_function("mimikaStudio.latent && mimikaStudio.latent.state !== 'loading'")
    pg.wait_for_function("!mimikaStudio.viewer.dirty")
    late = pg.evaluate("window.__shifts.filter(s => s.t > mimikaStudio.readyAt)")
    assert sum(s["value"] for s in late) < 0.01, late


def axe(pg) -> list[dict]:
    if not pg.evaluate("!!window.axe"):
        pg.add_script_tag(path=str(AXE))
    res = pg.evaluate("axe.run(document, {resultTypes: ['violations']})")
    return [{"id": v["id"], "impact": v["impact"], "nodes": [n["target"] for n in v["nodes"]][:5]}
            for v in res["violations"] if v["impact"] in ("serious", "critical")]


def test_axe_finds_no_serious_violations(studio):
    if not AXE.is_file():
        pytest.skip("axe-core is missing: run scripts/setup-node.sh")
    pg = studio
    assert axe(pg) == []
    pg.click("button[aria-label='Add a trigger to Head']")  # the trigger panel
    pg.locator('input.val[data-code="AU12"]').fill("1")
    pg.press('input.val[data-code="AU12"]', "Enter")
    pg.click("button[aria-label='AU06 L/R (left and right separately)']")
    assert axe(pg) == []
    pg.click("#tab-blend")
    pg.locator("#rules li summary").first.click()
    assert axe(pg) == []
    pg.click("#tab-latent")
    pg.wait_for_function("mimikaStudio.latent.state !== 'loading'")
    assert axe(pg) == []
    pg.click("#export-menu summary")
    pg.click("#layers-menu summary")
    assert axe(pg) == []


def test_every_control_is_named_and_apply_buttons_say_what(studio):
    pg = studio
    names = pg.locator("#expr-list button").evaluate_all(
        "bs => bs.map(b => b.getAttribute('aria-label'))")
    assert len(names) == len(set(names)) and "Apply happiness" in names
    assert "+TL: add happiness to the timeline" in names
    slider = pg.locator('input[type=range][data-code="AU06"]')
    assert slider.get_attribute("aria-label") == "AU06 Cheek Raiser"
    assert slider.get_attribute("aria-valuetext") == "0.00"
    unnamed = pg.evaluate("""[...document.querySelectorAll('input, select, textarea, button')]
      .filter(e => e.offsetParent !== null && e.type !== 'file')
      .filter(e => !(e.getAttribute('aria-label') || e.labels && e.labels.length
                     || (e.tagName === 'BUTTON' && e.textContent.trim())))
      .map(e => e.outerHTML.slice(0, 80))""")
    assert unnamed == []


def test_keyboard_skip_links_tabs_viewer_and_focus(studio):
    pg = studio
    pg.keyboard.press("Tab")
    assert pg.evaluate("document.activeElement.textContent") == "Skip to the 3D view"
    assert pg.locator(".skip-link").first.bounding_box()["y"] >= 0  # shown when focused
    pg.keyboard.press("Enter")
    assert pg.evaluate("document.activeElement.id") == "view"
    outline = pg.evaluate("getComputedStyle(document.activeElement).outlineStyle")
    assert outline != "none"  # visible focus
    cam = "mimikaStudio.viewer.camera.position.toArray()"
    before = pg.evaluate(cam)
    pg.keyboard.press("ArrowRight")
    pg.keyboard.press("-")
    assert pg.evaluate(cam) != before
    pg.keyboard.press("3")
    assert pg.get_attribute("#view-tools [data-view='profile']", "aria-pressed") == "true"
    # the side panel's tabs: arrow keys move between them
    pg.focus("#tab-expr")
    pg.keyboard.press("ArrowRight")
    assert pg.evaluate("document.activeElement.id") == "tab-blend"
    assert pg.is_visible("#pane-blend") and not pg.is_visible("#pane-expr")
    # the skip link to the timeline lands there
    pg.evaluate("document.activeElement.blur()")
    pg.focus(".skip-link >> nth=2")
    pg.keyboard.press("Enter")
    assert pg.evaluate("document.activeElement.id") == "tl-scroll"
