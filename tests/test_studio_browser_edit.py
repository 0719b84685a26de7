"""mimika studio in the browser: editing that forgives — undo/redo, Delete wherever focus is,
the unsaved-changes guard, drag to scrub, Space to play, triggers that never overlap, keyboard
triggers, project files from disk, and no stale speech after the text changes."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from studio_helpers import download_bytes, project_events, record, recorded

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]

ADD = "button[aria-label='Add a trigger to {}']"
DEFAULT_TEXT = "Good evening. Here is the news from mimika studio."


def undos(pg) -> int:
    return pg.evaluate("mimikaStudio.history.undos.length")


def test_undo_and_redo_every_edit(studio):
    pg = studio
    pg.locator('input[type=range][data-code="AU12"]').fill("0.8")
    pg.wait_for_function("mimikaStudio.weights().AU12 > 0.79")
    pg.click(ADD.format("Head"))
    assert len(project_events(pg, "head")) == 1
    pg.fill("#speech-text", "New words.")
    pg.wait_for_function("mimikaStudio.history.undos.length === 3")
    assert pg.is_enabled("#btn-undo") and not pg.is_enabled("#btn-redo")
    pg.click("#btn-undo")
    pg.wait_for_function(f"document.getElementById('speech-text').value === {DEFAULT_TEXT!r}")
    # Ctrl+Z wherever focus is (here the 3D view), except inside a text field
    pg.focus("#view")
    pg.keyboard.press("Control+z")
    pg.wait_for_function("mimikaStudio.project.timeline.channels.every(c => !c.events.length)")
    pg.keyboard.press("Control+z")
    pg.wait_for_function("!(mimikaStudio.weights().AU12 > 0)")
    assert pg.input_value('input[type=range][data-code="AU12"]') == "0"
    assert not pg.is_enabled("#btn-undo")
    pg.keyboard.press("Control+Shift+z")
    pg.wait_for_function("mimikaStudio.weights().AU12 > 0.79")
    pg.keyboard.press("Control+y")
    pg.wait_for_function("mimikaStudio.project.timeline.channels.some(c => c.events.length)")
    pg.click("#btn-redo")
    pg.wait_for_function("document.getElementById('speech-text').value === 'New words.'")


def test_delete_works_with_focus_on_a_button(studio):
    """Bug: Delete was ignored while focus was on a button."""
    pg = studio
    pg.click(ADD.format("Expressions"))
    assert len(project_events(pg)) == 1
    pg.focus("#zoom-in")
    pg.keyboard.press("Delete")
    pg.wait_for_function("mimikaStudio.project.timeline.channels.every(c => !c.events.length)")
    # but Delete inside a text field deletes text, not the trigger
    pg.click(ADD.format("Gaze"))
    pg.click("#speech-text")
    pg.keyboard.press("End")
    pg.keyboard.press("Delete")
    assert len(project_events(pg, "gaze")) == 1


def test_unsaved_changes_guard(studio, open_studio):
    """Bug: reloading dropped unsaved work without a prompt."""
    pg = studio
    pg.click(ADD.format("Blinks"))
    assert pg.evaluate("mimikaStudio.dirty()")
    with pg.expect_event("dialog") as info:
        pg.close(run_before_unload=True)
    assert info.value.type == "beforeunload"
    info.value.dismiss()  # stay: the work is still there
    assert len(project_events(pg, "blink")) == 1
    pg.fill("#project-name", "guarded")
    pg.click("#btn-save")
    pg.wait_for_selector(".toast.ok")
    assert not pg.evaluate("mimikaStudio.dirty()")
    with pg.expect_event("close"):
        pg.close(run_before_unload=True)  # saved: no question
    fresh = open_studio()
    assert not fresh.evaluate("mimikaStudio.dirty()")  # an untouched page never asks


def test_drag_the_playhead_to_scrub(studio):
    """Bug: the playhead could only be clicked, not dragged."""
    pg = studio
    pg.click(ADD.format("Expressions"))  # happiness 0–1.5 s
    pg.wait_for_function("mimikaStudio.player.tl"
                         " && mimikaStudio.player.tl.channels.includes('AU12')")
    box = pg.locator("#tl-ruler").bounding_box()
    pps = pg.evaluate("mimikaStudio.editor.pps")
    y = box["y"] + box["height"] / 2
    pg.mouse.move(box["x"] + 3.0 * pps, y)
    pg.mouse.down()
    assert pg.evaluate("mimikaStudio.editor.time") == pytest.approx(3.0, abs=0.05)
    pg.mouse.move(box["x"] + 0.75 * pps, y, steps=6)
    assert pg.evaluate("mimikaStudio.editor.time") == pytest.approx(0.75, abs=0.05)
    pg.wait_for_function("mimikaStudio.weights().AU12 > 0.1")  # the face follows the scrub
    pg.mouse.move(box["x"] + 2.0 * pps, y, steps=4)
    pg.mouse.up()
    assert pg.evaluate("mimikaStudio.editor.time") == pytest.approx(2.0, abs=0.05)
    # the playhead is a slider for the keyboard too
    pg.focus("#tl-knob")
    pg.keyboard.press("ArrowRight")
    assert pg.evaluate("mimikaStudio.editor.time") == pytest.approx(2.1, abs=1e-6)
    pg.keyboard.press("Home")
    assert pg.evaluate("mimikaStudio.editor.time") == 0
    assert pg.get_attribute("#tl-knob", "aria-valuetext") == "0.00 seconds"


def test_space_plays_and_stops(studio):
    pg = studio
    pg.click(ADD.format("Expressions"))
    pg.fill("#p-duration-num", "6")
    pg.press("#p-duration-num", "Enter")
    pg.wait_for_function("mimikaStudio.project.timeline.channels[0].events[0].duration === 6")
    pg.focus("#view")
    pg.keyboard.press(" ")
    pg.wait_for_function("mimikaStudio.player.mode !== 'idle'")
    pg.keyboard.press(" ")
    pg.wait_for_function("mimikaStudio.player.mode === 'idle'")
    assert pg.evaluate("mimikaStudio.editor.time") < 5.9  # stopped, not played to the end
    # on a button Space presses the button instead
    pps = pg.evaluate("mimikaStudio.editor.pps")
    pg.focus("#zoom-in")
    pg.keyboard.press(" ")
    assert pg.evaluate("mimikaStudio.player.mode") == "idle"
    assert pg.evaluate("mimikaStudio.editor.pps") > pps


def test_trigger_panel_cannot_make_triggers_overlap(studio):
    """Bug: setting start to 0 in the trigger panel hid a trigger under another (422)."""
    pg = studio
    pg.click(ADD.format("Expressions"))
    pg.click(ADD.format("Expressions"))  # the second, selected
    assert [e["start"] for e in project_events(pg)] == [0, 1.5]
    pg.locator("#p-start").fill("0")
    pg.fill("#p-start-num", "0")
    pg.press("#p-start-num", "Enter")
    evs = project_events(pg)
    assert [e["start"] for e in evs] == [0, 1.5]
    pg.click(".lane[data-track='face'] .ev >> nth=0")
    pg.fill("#p-duration-num", "10")
    pg.press("#p-duration-num", "Enter")
    evs = project_events(pg)
    assert evs[0]["start"] + evs[0]["duration"] <= evs[1]["start"] + 1e-9
    # a trigger added where there is no room goes to the next free slot
    pg.evaluate("mimikaStudio.editor.setTime(0.5)")
    pg.click(ADD.format("Expressions"))
    evs = sorted(project_events(pg), key=lambda e: e["start"])
    for a, b in itertools.pairwise(evs):
        assert a["start"] + a["duration"] <= b["start"] + 1e-9
    # and the server takes the timeline (no 422)
    pg.wait_for_function("mimikaStudio.player.tl && mimikaStudio.player.tl.values.length > 100")


def test_triggers_by_keyboard(studio):
    pg = studio
    pg.click(ADD.format("Expressions"))
    pg.focus(ADD.format("Blinks"))
    pg.keyboard.press("Tab")  # the next stop after the track buttons: the trigger
    assert pg.evaluate("document.activeElement.classList.contains('ev')")
    label = pg.evaluate("document.activeElement.getAttribute('aria-label')")
    assert label.startswith("happiness, Expressions track, 0.00 to 1.50 seconds")
    pg.keyboard.press("ArrowRight")
    pg.keyboard.press("Shift+ArrowRight")
    assert project_events(pg)[0]["start"] == pytest.approx(1.1)
    pg.keyboard.press("Alt+ArrowRight")
    assert project_events(pg)[0]["duration"] == pytest.approx(1.6)
    assert pg.evaluate("document.activeElement.classList.contains('ev')")  # focus stays on it
    pg.keyboard.press("Delete")
    assert project_events(pg) == []


def test_project_file_export_and_import(studio, tmp_path):
    pg = studio
    pg.fill("#speech-text", "Words from a file.")
    pg.click(ADD.format("Expressions"))
    pg.click(ADD.format("Head"))
    pg.fill("#project-name", "Grüße")
    pg.click("#export-menu summary")
    name, data = download_bytes(pg, lambda: pg.click("#btn-export-project"))
    assert name == "Grüße.json"
    doc = json.loads(data)
    assert doc["format"] == "mimika-project" and len(doc["timeline"]["channels"]) == 2
    pg.click("#btn-new")
    pg.wait_for_function("mimikaStudio.project.timeline.channels.length === 0")
    pg.set_input_files("#import-file", files=[{"name": "talk.json", "mimeType": "application/json",
                                               "buffer": data}])
    pg.wait_for_function("mimikaStudio.project.timeline.channels.length === 2")
    assert pg.input_value("#speech-text") == "Words from a file."
    assert pg.input_value("#project-name") == "talk"
    # a file naming an expression the library lacks is refused with the reason
    doc["timeline"]["channels"][0]["events"][0]["name"] = "no-such-face"
    pg.set_input_files("#import-file", files=[{"name": "bad.json", "mimeType": "application/json",
                                               "buffer": json.dumps(doc).encode()}])
    msg = pg.wait_for_selector(".toast.error:has-text('bad.json')").inner_text()
    assert "no expression called “no-such-face”" in msg and "/" not in msg.split("bad.json")[1]
    assert project_events(pg)[0]["name"] == "happiness"  # the open project is untouched
    pg.set_input_files("#import-file", files=[{"name": "notes.json", "mimeType": "application/json",
                                               "buffer": b"not json"}])
    pg.wait_for_selector(".toast.error:has-text('not a mimika project file')")
    # opening a file is one step of undo
    pg.focus("#view")
    pg.keyboard.press("Control+z")
    pg.wait_for_function("mimikaStudio.project.timeline.channels.length === 0")


def test_old_speech_does_not_replay_after_the_text_changes(studio):
    """Bug: after clearing the text, Play moved the mouth silently with the old subtitle."""
    pg = studio
    pg.fill("#speech-text", "Hello there, this is a test.")
    pg.click("#btn-speak")
    pg.wait_for_function("mimikaStudio.player.key && mimikaStudio.player.mode === 'idle'",
                         timeout=60_000)
    assert pg.evaluate("mimikaStudio.editor.words.length") > 0
    pg.fill("#speech-text", "")
    assert pg.evaluate("mimikaStudio.player.segments.length") == 0
    assert pg.evaluate("mimikaStudio.editor.words.length") == 0
    pg.click(ADD.format("Expressions"))  # something to play: 1.5 s of happiness
    record(pg)
    pg.click("#btn-play")
    pg.wait_for_function("window.__rec.some(f => f.mode !== 'idle')"
                         " && mimikaStudio.player.mode === 'idle'")
    played = [f for f in recorded(pg) if f["mode"] != "idle"]
    assert played and all(f["subtitle"] == "" for f in played)
    # the mouth moves only as the expression does (happiness parts the lips: one rise, one
    # hold, one fall), never as speech would (a syllable's opening and closing again)
    mouth = np.array([f["mouth"] for f in played])
    steps = np.sign(np.diff(mouth[np.abs(np.diff(mouth, prepend=mouth[0])) > 1e-3]))
    assert np.count_nonzero(np.diff(steps)) <= 1, mouth.round(2).tolist()
