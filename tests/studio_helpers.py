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


def _png_bytes(rgba) -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    return buf.getvalue()


def textured_glb(glb: bytes) -> bytes:
    """mimika's head GLB as a character's would come: the skin gets UVs, a base-colour texture
    (pure green) and a normal map; the brows become hair cards (a texture whose alpha cuts out
    strands, alpha blending). Used to check the viewer draws the materials a GLB carries."""
    import json
    import struct

    import numpy as np

    n = struct.unpack("<I", glb[12:16])[0]
    doc = json.loads(glb[20:20 + n])
    bin0 = 20 + n + 8
    binary = bytearray(glb[bin0:bin0 + doc["buffers"][0]["byteLength"]])

    def append(data: bytes) -> int:
        while len(binary) % 4:
            binary.append(0)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)})
        binary.extend(data)
        return len(doc["bufferViews"]) - 1

    def positions(acc: dict) -> np.ndarray:
        bv = doc["bufferViews"][acc["bufferView"]]
        off = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
        return np.frombuffer(bytes(binary[off:off + 12 * acc["count"]]), "<f4").reshape(-1, 3)

    def image(rgba) -> int:
        doc.setdefault("images", []).append({"bufferView": append(_png_bytes(rgba)),
                                             "mimeType": "image/png"})
        doc.setdefault("textures", []).append({"source": len(doc["images"]) - 1})
        return len(doc["textures"]) - 1

    green = np.zeros((16, 16, 4), np.uint8)
    green[..., 1], green[..., 3] = 255, 255
    flat = np.zeros((16, 16, 4), np.uint8)
    flat[...] = (128, 128, 255, 255)
    strands = np.zeros((16, 16, 4), np.uint8)
    strands[..., :3] = (60, 40, 30)
    strands[:, ::2, 3] = 255  # every other column: a strand; between them: nothing
    tex = {"green": image(green), "flat": image(flat), "strands": image(strands)}
    for mesh in doc["meshes"]:
        if mesh["name"] not in ("skin", "brows"):
            continue
        for prim in mesh["primitives"]:
            p = positions(doc["accessors"][prim["attributes"]["POSITION"]])
            lo, hi = p.min(0), p.max(0)
            uv = ((p[:, :2] - lo[:2]) / np.maximum(hi[:2] - lo[:2], 1e-6)).astype("<f4")
            doc["accessors"].append({"bufferView": append(uv.tobytes()), "componentType": 5126,
                                     "count": len(uv), "type": "VEC2"})
            prim["attributes"]["TEXCOORD_0"] = len(doc["accessors"]) - 1
    for m in doc["materials"]:
        if m["name"] == "skin":
            m["pbrMetallicRoughness"]["baseColorFactor"] = [1, 1, 1, 1]
            m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex["green"]}
            m["normalTexture"] = {"index": tex["flat"]}
        if m["name"] == "brow":
            m["name"] = "hair"
            m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex["strands"]}
            m["alphaMode"] = "BLEND"
            m["doubleSided"] = True
    doc["buffers"][0]["byteLength"] = len(binary)
    while len(binary) % 4:
        binary.append(0)
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A)
            + js + struct.pack("<II", len(binary), 0x004E4942) + bytes(binary))
