"""mimika studio in the browser: FACS-native input (typed values, A–E letters), per-rule AU
Blender switches, PNG stills and contact sheets, the head picker, view presets, the looks and
speech with the newsreader's behaviour layers."""

from __future__ import annotations

import io

import numpy as np
import pytest

from studio_helpers import download_bytes, record, recorded, weights

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]

AU12 = 'input.val[data-code="AU12"]'


def _png(data: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def test_typed_values_and_facs_letters(studio):
    pg = studio
    pg.fill(AU12, "C")
    pg.press(AU12, "Enter")
    pg.wait_for_function("Math.abs(mimikaStudio.weights().AU12 - 0.6) < 1e-6")
    assert pg.input_value(AU12) == "0.60 C"
    slider = pg.locator('input[type=range][data-code="AU12"]')
    assert slider.get_attribute("aria-valuetext") == "0.60, FACS C"
    assert slider.get_attribute("aria-label") == "AU12 Lip Corner Puller"
    for typed, value in (("0.35", 0.35), ("80%", 0.8), ("e", 1.0), (".1", 0.1)):
        pg.fill(AU12, typed)
        pg.press(AU12, "Enter")
        pg.wait_for_function(f"Math.abs(mimikaStudio.weights().AU12 - {value}) < 1e-6")
    pg.fill(AU12, "lots")
    pg.press(AU12, "Enter")
    msg = pg.wait_for_selector(".toast.error").inner_text()
    assert "FACS letter A–E" in msg and pg.get_attribute(AU12, "aria-invalid") == "true"
    assert weights(pg)["AU12"] == pytest.approx(0.1)
    # a letter key on a focused slider sets that intensity
    slider.focus()
    pg.keyboard.press("b")
    pg.wait_for_function("Math.abs(mimikaStudio.weights().AU12 - 0.4) < 1e-6")
    # sided AUs: both sides take letters
    pg.click("button[aria-label='AU12 L/R (left and right separately)']")
    pg.fill('input.val[data-code="AU12L"]', "D")
    pg.press('input.val[data-code="AU12L"]', "Enter")
    pg.wait_for_function("Math.abs(mimikaStudio.weights().AU12L - 0.8) < 1e-6")


def test_per_rule_blender_switches_with_explanations(studio):
    pg = studio
    for code in ("AU12", "AU15"):
        pg.fill(f'input.val[data-code="{code}"]', "1")
        pg.press(f'input.val[data-code="{code}"]', "Enter")
    pg.wait_for_function("mimikaStudio.weights().AU12 < 0.01")  # 12<15Z: AU15 wins
    pg.click("#tab-blend")
    rule = pg.locator("#rules li[data-rule='12<15Z']")
    assert "fired" in rule.get_attribute("class")
    assert "a strong AU15 hides AU12" in rule.inner_text()
    rule.locator("summary").click()
    why = rule.locator("details p").inner_text()
    assert "Lip Corner Depressor (AU15)" in why and "0.9" in why
    assert rule.locator("label").get_attribute("title") == why  # on hover too
    rule.locator("input[type=checkbox]").uncheck()
    pg.wait_for_function("mimikaStudio.weights().AU12 > 0.99")
    assert pg.evaluate("mimikaStudio.project.settings.blender_off") == ["12<15Z"]
    pg.fill("#rule-filter", "AU43")
    assert pg.locator("#rules li[data-rule]").count() >= 4
    assert all("43" in t for t in pg.locator("#rules li[data-rule]").all_inner_texts())
    pg.focus("#view")
    pg.keyboard.press("Control+z")  # the switch is undoable
    pg.wait_for_function("mimikaStudio.weights().AU12 < 0.01")
    assert pg.evaluate("mimikaStudio.project.settings.blender_off") == []


@pytest.mark.render
def test_png_still_and_contact_sheet(studio):
    pg = studio
    pg.fill(AU12, "1")
    pg.press(AU12, "Enter")
    pg.fill("#project-name", "Zażółć")
    pg.click("#export-menu summary")
    name, data = download_bytes(pg, lambda: pg.click("#btn-export-png"))
    img = _png(data)
    assert name == "Zażółć-pose.png" and img.shape == (480, 640, 3)
    assert pg.is_enabled("#btn-export-png")
    pg.click("#export-menu summary")
    name, data = download_bytes(pg, lambda: pg.click("#btn-export-sheet"))
    sheet = _png(data)
    n = pg.locator("#expr-list li").count()
    assert name == "Zażółć-library.png" and sheet.shape[0] > 200 * (n // 6)


def test_head_picker_lists_heads_and_switches_live(studio, server):
    from mimika.face.heads import list_heads

    pg = studio
    heads = list_heads()
    options = pg.locator("#head-select option")
    assert options.all_inner_texts() == [h.name if h.available else f"{h.name} (not installed)"
                                         for h in heads]
    other = next((h.name for h in heads if h.available and h.name != "builtin"), None)
    if other is None:
        pytest.skip("only the built-in head is installed here (set MIMIKA_ICT_DIR for ICT)")
    size = """(() => { let n = 0; mimikaStudio.viewer.root.traverse(o => {
      if (o.isMesh) n += o.geometry.attributes.position.count; }); return n; })()"""
    n0 = pg.evaluate(size)
    pg.fill(AU12, "0.7")
    pg.press(AU12, "Enter")
    pg.select_option("#head-select", other)
    pg.wait_for_function(f"mimikaStudio.project.settings.head === {other!r}", timeout=180_000)
    pg.wait_for_function("mimikaStudio.weights().AU12 > 0.69")  # the pose moved over
    assert pg.evaluate(size) != n0  # another mesh is shown
    pg.focus("#view")
    pg.keyboard.press("Control+z")
    pg.wait_for_function("mimikaStudio.state.head === 'builtin'", timeout=180_000)
    assert pg.input_value("#head-select") == "builtin"
    assert pg.evaluate("mimikaStudio.project.settings.head") == "builtin"


def test_view_presets_and_looks(studio):
    pg = studio
    cam = "mimikaStudio.viewer.camera.position.toArray()"
    front = pg.evaluate(cam)
    pg.click("#view-tools [data-view='profile']")
    side = pg.evaluate(cam)
    assert side[0] > abs(side[2]) * 5  # the camera is on the +x side
    assert pg.get_attribute("#view-tools [data-view='profile']", "aria-pressed") == "true"
    assert pg.evaluate("mimikaStudio.project.settings.view") == "profile"
    pg.focus("#view")
    pg.keyboard.press("ArrowLeft")  # orbit by keyboard
    assert pg.evaluate(cam) != side
    pg.keyboard.press("1")
    pg.wait_for_function("mimikaStudio.project.settings.view === 'front'")
    assert pg.evaluate(cam) == pytest.approx(front, abs=1e-6)
    # the news look: another backdrop (blue set, desk) and light
    before = _png(pg.locator("#view").screenshot())
    pg.select_option("#look-select", "news")
    pg.wait_for_function("mimikaStudio.viewer.look.name === 'news'")
    pg.wait_for_function("!mimikaStudio.viewer.dirty")  # drawn
    after = _png(pg.locator("#view").screenshot())
    corner = (slice(0, 40), slice(-40, None))  # top right: no buttons there
    assert after[corner].mean(axis=(0, 1))[2] > after[corner].mean(axis=(0, 1))[0]  # blue set
    assert np.abs(before.astype(int) - after).mean() > 3


def test_speak_runs_the_behaviour_layers(studio):
    """Bug: Speak moved only the mouth; the newsreader's layers now run too (switchable)."""
    pg = studio
    pg.fill("#speech-text", "Good evening. Here is the news of the day, read slowly and calmly.")
    record(pg)
    pg.click("#btn-speak")
    pg.wait_for_function("mimikaStudio.player.key && mimikaStudio.player.mode === 'idle'")
    head_moved = max(f["head"] for f in recorded(pg) if f["mode"] == "live")  # sin(angle/2)
    chans = set(pg.evaluate("mimikaStudio.player.segments.flatMap(s => s.channels)"))
    assert {"AU45", "AU06", "AU01"} <= chans  # blink, greeting smile, brows
    assert chans & {"AU51", "AU52", "AU53", "AU54", "AU55", "AU56"}
    assert chans & {"AU61", "AU62", "AU63", "AU64"}
    assert head_moved > 1e-3  # more than 0.1°
    pg.click("#layers-menu summary")
    for box in pg.locator("#layers input").all():
        box.uncheck()
    assert pg.evaluate("mimikaStudio.project.settings.behaviour") == []
    pg.click("#btn-speak")
    pg.wait_for_function("mimikaStudio.player.key && mimikaStudio.player.mode === 'idle'")
    chans = set(pg.evaluate("mimikaStudio.player.segments.flatMap(s => s.channels)"))
    assert not chans & {"AU45", "AU06", "AU01", "AU51", "AU52", "AU53", "AU54", "AU61", "AU62"}


def test_viewer_draws_the_materials_a_glb_carries(browser, server):
    """A character's GLB (textures, normal map, hair cards with alpha) keeps its materials in
    the live view, with mimika's lighting on top, and its morph targets still move."""
    import base64

    from studio_helpers import textured_glb

    ctx = browser.new_context(viewport={"width": 1024, "height": 768})
    try:
        pg = ctx.new_page()
        errors = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)

        def textured(route):
            route.fulfill(body=textured_glb(route.fetch().body()),
                          headers={"content-type": "model/gltf-binary"})

        pg.route("**/api/head.glb*", textured)
        pg.goto(server["url"])
        pg.wait_for_function("window.mimikaStudio && mimikaStudio.ready === true",
                             timeout=120_000)
        mats = pg.evaluate("""(() => { const out = {};
          mimikaStudio.viewer.root.traverse(o => { if (o.isMesh)
            for (const m of [].concat(o.material)) out[m.name] = {map: !!m.map,
              normalMap: !!m.normalMap, a2c: m.alphaToCoverage, transparent: m.transparent,
              skinned: !!o.isSkinnedMesh}; });
          return out; })()""")
        assert mats["skin"]["map"] and mats["skin"]["normalMap"] and mats["skin"]["skinned"]
        assert mats["hair"]["map"] and mats["hair"]["a2c"] and not mats["hair"]["transparent"]
        shot = pg.evaluate("mimikaStudio.viewer.still(320, 240)")
        img = _png(base64.b64decode(shot.split(",", 1)[1])).astype(int)
        cheek = img[150:170, 130:190].reshape(-1, 3).mean(0)
        assert cheek[1] > 2 * cheek[0] and cheek[1] > 2 * cheek[2]  # the green texture, lit
        pg.evaluate("mimikaStudio.panel.setPose({AU12: 1})")
        pg.wait_for_function("mimikaStudio.weights().AU12 > 0.99")
        assert errors == []
    finally:
        ctx.close()


def test_lip_sync_a_recording_of_the_text(studio, tmp_path):
    """A recording (any format the browser reads) with its text: the mouth follows it."""
    from mimika.speech import synthesize
    from mimika.speech.audio import write_wav

    pg = studio
    text = "Good evening. The weather stays dry and mild."
    rec = synthesize(text, rate=130)
    wav = tmp_path / "take.wav"
    write_wav(wav, rec.audio, sr=rec.sr)
    pg.fill("#speech-text", text)
    pg.set_input_files("#recording-file", str(wav))
    pg.wait_for_selector(".toast.ok:has-text('take.wav')")
    assert pg.evaluate("mimikaStudio.player.recording") == "take.wav"
    assert pg.evaluate("mimikaStudio.player.duration") == pytest.approx(rec.duration, abs=0.05)
    words = pg.evaluate("mimikaStudio.editor.words.map(w => w.text.trim())")
    assert words[0] == "Good" and words[-1] == "mild"
    record(pg)
    pg.click("#btn-play")
    pg.wait_for_function("window.__rec.some(f => f.mode === 'audio')"
                         " && mimikaStudio.player.mode === 'idle'")
    played = [f for f in recorded(pg) if f["mode"] == "audio"]
    assert max(f["mouth"] for f in played) > 0.1
    assert any("weather" in f["subtitle"] for f in played)
    # the CSV export carries the recording's length, not a new synthesis
    pg.click("#export-menu summary")
    _, data = download_bytes(pg, lambda: pg.click("#btn-export-csv"))
    rows = data.decode().strip().splitlines()
    assert (len(rows) - 1) / 30 == pytest.approx(rec.duration, abs=0.1)
    # changing the text forgets the recording
    pg.fill("#speech-text", "Something else.")
    assert pg.evaluate("mimikaStudio.player.recording") is None
