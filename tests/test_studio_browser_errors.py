"""mimika studio in the browser: the bugs a new user met, reproduced and fixed — expression
saves that leaked paths, flags and regexes; project names; missing expressions; long texts;
double MP4 exports; numbers in speech. Every message is checked for jargon by the fixture."""

from __future__ import annotations

import json

import pytest

from studio_helpers import download_bytes, project_events

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]


def expressions(pg) -> dict[str, dict]:
    return {x["name"]: x for x in pg.evaluate("fetch('/api/expressions').then(r => r.json())")
            ["expressions"]}


def set_au(pg, code: str, value: str) -> None:
    pg.fill(f'input.val[data-code="{code}"]', value)
    pg.press(f'input.val[data-code="{code}"]', "Enter")


def test_expression_save_speaks_plainly_and_can_replace(studio):
    """Bug: save errors showed a server path, a CLI flag and raw regexes, threw unhandled
    rejections, and there was no way to overwrite."""
    pg = studio
    set_au(pg, "AU12", "0.8")
    pg.fill("#expr-name", "happiness")
    pg.click("#btn-expr-save")
    dialog = pg.wait_for_selector("#dialog[open]")
    assert "built-in expression" in dialog.inner_text()
    pg.click("#dialog-cancel")
    assert expressions(pg)["happiness"]["builtin"]
    pg.fill("#expr-name", "my smile!")
    pg.click("#btn-expr-save")
    msg = pg.wait_for_selector(".toast.error").inner_text()
    assert "cannot name an expression" in msg and "my-smile" in msg
    assert pg.get_attribute("#expr-name", "aria-invalid") == "true"
    pg.fill("#expr-name", "My Smile")
    pg.click("#btn-expr-save")
    pg.wait_for_selector(".toast.ok:has-text('Saved “my-smile”')")
    assert expressions(pg)["my-smile"]["aus"] == {"AU12": 0.8}
    set_au(pg, "AU12", "0.4")
    pg.fill("#expr-name", "my-smile")
    pg.click("#btn-expr-save")
    assert "already an expression called “my-smile”" in pg.wait_for_selector(
        "#dialog[open]").inner_text()
    pg.click("#dialog-ok")  # Replace
    pg.wait_for_function("fetch('/api/expressions').then(r => r.json()).then(d => d.expressions"
                         ".find(e => e.name === 'my-smile').aus.AU12 === 0.4)")
    pg.click("#expr-list li[data-name='my-smile'] button[aria-label='Delete my-smile']")
    pg.click("#dialog-ok")
    pg.wait_for_selector("#expr-list li[data-name='my-smile']", state="detached")


def test_project_names_in_any_script(studio, server):
    """Bug: '-dash-first' was refused though the message allowed '-'; German and Polish
    names were refused although the studio speaks both."""
    pg = studio
    for name in ("-dash-first", "Zażółć gęślą jaźń", "Grüße aus Köln"):
        pg.fill("#project-name", name)
        pg.click("#btn-save")
        pg.wait_for_selector(f".toast.ok:has-text('Saved “{name}”')")
        assert (server["dir"] / "projects" / f"{name}.json").is_file()
    assert "Grüße aus Köln" in pg.locator("#project-list option").all_inner_texts()
    pg.fill("#project-name", "a/b")
    pg.click("#btn-save")
    assert "cannot be a project name" in pg.wait_for_selector(".toast.error").inner_text()
    assert pg.get_attribute("#project-name", "aria-invalid") == "true"


def test_project_with_a_missing_expression(studio, server):
    """Bug: a project naming a missing expression was accepted and then showed 'neutral'."""
    pg = studio
    doc = pg.evaluate("JSON.parse(JSON.stringify(mimikaStudio.project))")
    doc["timeline"]["channels"] = [{"name": "face", "override": False, "ease": "cosine",
                                    "bridge": None, "events": [
                                        {"kind": "expression", "name": "gone-face", "start": 0.5,
                                         "duration": 1.0, "intensity": 0.8}]}]
    (server["dir"] / "projects" / "old talk.json").write_text(json.dumps(doc))  # another tool
    pg.click("#btn-new")
    pg.evaluate("document.getElementById('project-list').append(new Option('old talk', "
                "'old talk'))")
    pg.select_option("#project-list", "old talk")
    pg.click("#btn-load")
    msg = pg.wait_for_selector(".toast.error:has-text('gone-face')").inner_text()
    assert "not in your library" in msg and "trigger 1" in msg
    assert pg.input_value("#p-name") == "gone-face"  # its real name, not "neutral"
    assert "missing" in pg.get_attribute(".lane[data-track='face'] .ev", "class")
    pg.fill("#project-name", "old talk")
    pg.click("#btn-save")  # refused until it is fixed
    pg.wait_for_selector(".toast.error:has-text('gone-face') >> nth=1")
    pg.select_option("#p-name", "surprise")
    pg.click("#btn-save")
    pg.wait_for_selector(".toast.ok:has-text('Saved “old talk”')")
    saved = json.loads((server["dir"] / "projects" / "old talk.json").read_text())
    assert saved["timeline"]["channels"][0]["events"][0]["name"] == "surprise"


def test_long_text_is_counted_and_never_cut(studio):
    """Bug: text over 5 000 characters was cut mid-word without a word."""
    pg = studio
    text = " ".join(["Words of a very long bulletin."] * 175)  # 5 424 characters
    pg.fill("#speech-text", text)
    assert len(pg.input_value("#speech-text")) == len(text) > 5000
    count = pg.locator("#text-count")
    assert "over" in count.get_attribute("class")
    assert f"{len(text):,} / 5,000 characters" in count.inner_text()
    assert pg.get_attribute("#speech-text", "aria-invalid") == "true"
    pg.click("#btn-speak")
    msg = pg.wait_for_selector(".toast.error").inner_text()
    assert "at most 5,000" in msg and f"by {len(text) - 5000:,} characters" in msg
    assert pg.evaluate("mimikaStudio.player.mode") == "idle"
    assert pg.input_value("#speech-text") == text  # nothing was cut
    pg.fill("#speech-text", text[:4990])
    assert "over" not in count.get_attribute("class")


def test_mp4_export_runs_once_and_says_so(studio):
    """Bug: the MP4 toast vanished after 1.5 s, the button stayed enabled and a double click
    rendered twice."""
    pg = studio
    if not pg.evaluate("mimikaStudio.state.status.features.mp4"):
        pytest.skip("MP4 export needs the renderer and PyAV on the server")
    requests = []
    pg.on("request", lambda r: requests.append(r.url) if "/api/export/mp4" in r.url else None)
    set_au(pg, "AU12", "0.8")
    pg.fill("#speech-text", "")
    with pg.expect_download(timeout=180_000) as d:
        pg.evaluate("const b = document.getElementById('btn-export-mp4'); b.click(); b.click();")
        note = pg.wait_for_selector(".toast.info:has-text('Rendering')")
        assert "Cancel" in note.inner_text()
        assert pg.is_disabled("#btn-export-mp4")
        assert pg.get_attribute("#btn-export-mp4", "aria-busy") == "true"
    assert d.value.suggested_filename == "mimika.mp4"
    assert len(requests) == 1
    pg.wait_for_selector(".toast.ok:has-text('mimika.mp4')")
    assert pg.is_enabled("#btn-export-mp4")
    # a long render can be cancelled
    pg.evaluate("document.getElementById('btn-export-mp4').click()")
    pg.click(".toast.info button:has-text('Cancel')")
    pg.wait_for_selector(".toast.info:has-text('cancelled')")
    assert pg.is_enabled("#btn-export-mp4")


def test_numbers_read_once_in_subtitles_and_speech_track(studio):
    """Bug: '12345' and '3.14159' were repeated word by word in the subtitle and Speech track."""
    pg = studio
    pg.fill("#speech-text", "I paid $100 for 12345 items, about 3.14159 each.")
    pg.click("#btn-speak")
    pg.wait_for_function("mimikaStudio.player.key && mimikaStudio.player.mode === 'idle'")
    words = pg.evaluate("mimikaStudio.editor.words.map(w => w.text.trim())")
    assert not any(w.startswith(".14159") or w == "2345" for w in words), words
    assert words.count("12345") == 1 and words.count("3.14159") == 1
    assert words[:3] == ["I", "paid", "$100"]


def test_gltf_export_of_a_project_with_unicode_name(studio):
    pg = studio
    pg.click("button[aria-label='Add a trigger to Expressions']")
    pg.fill("#speech-text", "")
    pg.fill("#project-name", "Wiadomości")
    pg.click("#export-menu summary")
    name, data = download_bytes(pg, lambda: pg.click("#btn-export-gltf"))
    assert name == "Wiadomości.glb" and data[:4] == b"glTF"
    assert project_events(pg)[0]["name"] == "happiness"
