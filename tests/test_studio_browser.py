"""mimika studio in a real browser (Debian's Chromium driven by Playwright).

Run ``scripts/setup-browser.sh`` (Chromium) and ``scripts/setup-studio.sh`` (three.js) first;
without them these tests skip with the command to run.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from studio_helpers import record, recorded, weights

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]  # fixtures: server, browser, open_studio, studio


@pytest.fixture
def page(studio):
    return studio


def test_au12_slider_moves_the_morph_target(page):
    assert weights(page).get("AU12", 0) == 0
    page.locator('input[type=range][data-code="AU12"]').fill("0.8")
    page.wait_for_function("mimikaStudio.weights().AU12 > 0.79")
    # AU Blender trace: AU15 strong suppresses AU12
    page.locator('input[type=range][data-code="AU15"]').fill("1")
    page.wait_for_function("document.getElementById('trace').textContent.includes('12<15Z')")
    page.wait_for_function("mimikaStudio.weights().AU12 < 0.01")
    # left/right toggle splits AU12 into AU12L and AU12R
    page.locator('input[type=range][data-code="AU15"]').fill("0")
    page.click("button[aria-label='AU12 L/R (left and right separately)']")
    page.locator('input[type=range][data-code="AU12L"]').fill("0.5")
    page.wait_for_function("mimikaStudio.weights().AU12L > 0.49")
    assert weights(page)["AU12R"] == pytest.approx(0.8, abs=0.01)


def test_head_and_eye_sliders_turn_joints(page):
    page.locator('input[type=range][data-code="AU51"]').fill("1")
    q = page.evaluate("mimikaStudio.viewer.headJoint.quaternion.toArray()")
    assert abs(q[3]) < 0.99


REPLAY_STATE = """(() => { const p = mimikaStudio.player, a = p.audio; return {
    mode: p.mode, key: p.key, duration: p.duration, end: p.end(), playError: p.playError,
    src: a.src, readyState: a.readyState, networkState: a.networkState,
    error: a.error && a.error.code, paused: a.paused, currentTime: a.currentTime}; })()"""


def test_speak_plays_audio_and_moves_the_mouth(page, record_property):
    page.fill("#speech-text", "Hello, this is the news. We talk about the weather.")
    record(page)
    page.click("#btn-speak")
    page.wait_for_function("mimikaStudio.player.mode === 'idle' && mimikaStudio.player.key")
    live = [f for f in recorded(page) if f["mode"] == "live" and f["clock"] is not None]
    assert max(f["mouth"] for f in live) > 0.1
    clock = [f["clock"] for f in live]
    assert len(set(clock)) > 1 and clock[-1] > clock[0]  # the audio clock advances
    assert any("news" in f["subtitle"] or "weather" in f["subtitle"] for f in live)
    m = page.evaluate("mimikaStudio.metrics()")
    record_property("speak_to_first_audio_ms", m["firstAudioMs"])
    record_property("speak_to_first_motion_ms", m["firstMotionMs"])
    print("studio latency:", json.dumps({k: m.get(k) for k in (
        "firstAudioMs", "firstMotionMs", "serverFirstAudioMs", "outputLatencyMs")}))
    # replay through <audio>: its currentTime is the clock
    record(page)
    page.click("#btn-play")
    try:
        page.wait_for_function("mimikaStudio.audio().currentTime > 0.3", timeout=30_000)
    except Exception:
        state = page.evaluate(REPLAY_STATE)
        pytest.fail(f"replay did not advance the <audio> clock: {state}")
    page.wait_for_function("mimikaStudio.player.mode === 'idle'")
    played = [f for f in recorded(page) if f["mode"] == "audio"]
    assert max(f["mouth"] for f in played) > 0.1
    assert any("weather" in f["subtitle"] for f in played)


def test_timeline_drag_and_trigger_panel(page):
    page.click("button[aria-label='Add a trigger to Expressions']")
    ev = page.locator(".lane[data-track='face'] .ev").first
    box = ev.bounding_box()
    start0 = page.evaluate("mimikaStudio.project.timeline.channels"
                           ".find(c => c.name === 'face').events[0].start")
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] / 2 + 110, box["y"] + box["height"] / 2, steps=5)
    page.mouse.up()
    start1 = page.evaluate("mimikaStudio.project.timeline.channels"
                           ".find(c => c.name === 'face').events[0].start")
    assert start1 == pytest.approx(start0 + 1.0, abs=0.1)
    # resize from the right edge
    box = ev.bounding_box()
    page.mouse.move(box["x"] + box["width"] - 2, box["y"] + 5)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] + 53, box["y"] + 5, steps=4)
    page.mouse.up()
    dur = page.evaluate("mimikaStudio.project.timeline.channels"
                        ".find(c => c.name === 'face').events[0].duration")
    assert dur == pytest.approx(2.0, abs=0.1)
    page.locator("#p-intensity").fill("0.4")
    page.locator("#p-onset").fill("0.5")
    e = page.evaluate("mimikaStudio.project.timeline.channels"
                      ".find(c => c.name === 'face').events[0]")
    assert e["intensity"] == pytest.approx(0.4) and e["onset"] == pytest.approx(0.5)


def test_save_reload_same_project(page, server):
    page.fill("#speech-text", "Saved words.")
    page.click("button[aria-label='Add a trigger to Expressions']")
    page.click("button[aria-label='Add a trigger to Head']")
    page.click("button[aria-label='Add a trigger to Gaze']")
    page.click("button[aria-label='Add a trigger to Blinks']")
    page.fill("#project-name", "browser-test")
    page.click("#btn-save")
    page.wait_for_selector(".toast.ok")
    before = page.evaluate("JSON.parse(JSON.stringify(mimikaStudio.project))")
    on_disk = json.loads((Path(server["dir"]) / "projects" / "browser-test.json").read_text())
    page.reload()
    page.wait_for_function("window.mimikaStudio && window.mimikaStudio.ready === true",
                           timeout=120_000)
    page.wait_for_selector("#project-list option[value='browser-test']", state="attached")
    page.select_option("#project-list", "browser-test")
    page.click("#btn-load")
    page.wait_for_function("mimikaStudio.project.timeline.channels.length === 4")
    after = page.evaluate("JSON.parse(JSON.stringify(mimikaStudio.project))")
    assert after == on_disk
    assert after["timeline"]["channels"] == [
        {**c, "bridge": None} for c in sorted(before["timeline"]["channels"],
                                              key=lambda c: c["name"])]
    assert page.input_value("#speech-text") == "Saved words."


def test_invalid_project_name_is_rejected_in_the_ui(page, server):
    page.fill("#project-name", "../evil")
    page.click("#btn-save")
    toast = page.wait_for_selector(".toast.error")
    assert "cannot be a project name" in toast.inner_text()
    assert not list(Path(server["dir"]).rglob("evil*"))


def test_mp4_export_says_when_unavailable(page):
    # pretend the server has no renderer: the page must say so instead of failing silently
    page.evaluate("mimikaStudio.state.status.features.mp4 = false;"
                  "mimikaStudio.state.status.features.mp4_reason = "
                  "\"MP4 export isn't available: av is not installed\"")
    page.click("#export-menu summary")
    page.click("#btn-export-mp4")
    assert "isn't available" in page.wait_for_selector(".toast.error").inner_text()


def test_gltf_export_downloads(page):
    page.locator('input[type=range][data-code="AU12"]').fill("1")
    with page.expect_download() as d:
        page.click("#export-menu summary")
        page.click("#btn-export-gltf")
    path = d.value.path()
    assert Path(path).read_bytes()[:4] == b"glTF"


def test_screenshot(page, tmp_path):
    page.locator('input[type=range][data-code="AU12"]').fill("0.7")
    page.locator('input[type=range][data-code="AU06"]').fill("0.5")
    page.wait_for_function("mimikaStudio.weights().AU06 > 0.49")
    out = tmp_path / "studio.png"
    page.screenshot(path=str(out))
    assert out.stat().st_size > 20_000
