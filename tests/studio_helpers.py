"""Helpers of the studio's browser tests (the fixtures are in ``studio_pages``)."""

from __future__ import annotations

from pathlib import Path

#: the repository's node tools (glTF validator, three.js, axe-core): scripts/setup-node.sh
AXE = Path(__file__).resolve().parents[1] / "tools" / "node_modules" / "axe-core" / "axe.min.js"
#: a loaded 2-core machine renders a frame in ~1 s; speech of a sentence takes seconds
TIMEOUT_MS = 60_000


def weights(pg) -> dict[str, float]:
    return pg.evaluate("mimikaStudio.weights()")


def project_events(pg, channel: str = "face") -> list[dict]:
    return pg.evaluate("(ch) => { const c = mimikaStudio.project.timeline.channels"
                       ".find(c => c.name === ch); return c ? c.events : []; }", channel)


def download_bytes(pg, click) -> tuple[str, bytes]:
    """Run ``click()`` and return the download's suggested name and bytes."""
    with pg.expect_download(timeout=TIMEOUT_MS * 3) as d:
        click()
    return d.value.suggested_filename, Path(d.value.path()).read_bytes()


RECORD = """() => { window.__rec = []; const mouth = ["AU25", "AU26", "AU22", "AU18", "AU24"];
  const tick = () => { const s = mimikaStudio, w = s.weights(), q = s.viewer.headJoint.quaternion;
    window.__rec.push({mode: s.player.mode, clock: s.clock(),
      mouth: Math.max(0, ...mouth.map(c => w[c] || 0)), head: Math.hypot(q.x, q.y, q.z),
      subtitle: getComputedStyle(document.getElementById("subtitle")).display === "none" ? ""
        : document.getElementById("subtitle").textContent});
    if (window.__rec.length < 20000) requestAnimationFrame(tick); };
  tick(); }"""


def record(pg) -> None:
    """Start recording, every animation frame in the page, the player's mode and clock, the
    mouth's largest weight, the head joint's rotation (sin of half its angle) and the
    subtitle; :func:`recorded` returns the frames (no sampling from outside the page)."""
    pg.evaluate(RECORD)


def recorded(pg) -> list[dict]:
    return pg.evaluate("window.__rec")
