"""Headless rendering: what a user sees in the PNGs."""

import os
import threading

import numpy as np
import pytest
from PIL import Image

from mimika import ParameterError
from mimika.errors import RenderError
from mimika.render import VIEWS, Renderer, contact_sheet, save_png

pytestmark = pytest.mark.render
SIZE = (320, 240)


@pytest.fixture(scope="module")
def renderer(builtin_rig):
    with Renderer(builtin_rig.head, size=SIZE) as r:
        yield r


def background_mask(img):
    """Pixels that differ from the backdrop gradient (estimated from the image border)."""
    edge = np.concatenate([img[:, :4], img[:, -4:]], axis=1).astype(int)  # left/right strips
    row_bg = np.median(edge, axis=1)[:, None, :]
    return np.abs(img.astype(int) - row_bg).sum(2) > 30


def test_image_has_size_and_the_head_fills_the_centre(renderer, builtin_rig):
    img = renderer.render()
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    head = background_mask(img)
    assert 0.25 < head.mean() < 0.8
    lm = renderer.camera("front").project(builtin_rig.head.landmark_points(), SIZE)
    (x0, y0), (x1, _), (_, y1) = lm[39], lm[42], lm[33]  # inner eye corners, nose tip
    assert 140 < x0 < x1 < 180 and 80 < y0 < y1 < 160  # the face is in the middle
    assert head[round(y0) + 2:round(y1), round(x0) + 2:round(x1) - 1].all()
    xs = np.nonzero(head)[1]
    assert abs(xs.mean() - 160) < 20  # centred left–right


def test_moving_vertices_changes_pixels_there_and_not_far_away(renderer, builtin_rig):
    base = renderer.render().astype(int)
    pos = builtin_rig.deform({"AU27": 1.0})
    moved = renderer.render(pos).astype(int)
    cam = renderer.camera("front")
    chin = cam.project(builtin_rig.head.landmark_points()[[8, 57]], SIZE).mean(0).astype(int)
    brow = cam.project(builtin_rig.head.landmark_points()[[19, 24]], SIZE).mean(0).astype(int)
    diff = np.abs(base - moved).sum(2)
    near = diff[chin[1] - 15:chin[1] + 15, chin[0] - 20:chin[0] + 20]
    far = diff[brow[1] - 10:brow[1] + 10, brow[0] - 30:brow[0] + 30]
    assert near.mean() > 20 and far.max() < 10


def test_views_differ_and_unknown_view_names_the_valid_ones(renderer):
    imgs = [renderer.render(view=v).astype(int) for v in VIEWS]
    for a, b in [(0, 1), (1, 2), (0, 2)]:
        assert np.abs(imgs[a] - imgs[b]).mean() > 5
    with pytest.raises(ParameterError, match="valid views: front, three-quarter, profile"):
        renderer.render(view="top")


def test_iris_is_darker_than_the_sclera(renderer, builtin_rig):
    img = renderer.render().astype(float)
    cam = renderer.camera("front")
    eye = builtin_rig.head["eye_L"]
    centre = eye.pivot + np.array([0, 0, 1.2])  # front of the eyeball: the pupil/iris
    side = eye.pivot + np.array([0.85, 0.0, 0.85])  # toward the outer corner: sclera
    (cx, cy), (sx, sy) = cam.project(np.array([centre, side]), SIZE).astype(int)
    assert img[cy, cx].sum() < 0.6 * img[sy, sx].sum()


def test_renders_from_other_threads_are_identical(renderer):
    a = renderer.render()
    out = []
    t = threading.Thread(target=lambda: out.append(renderer.render()))
    t.start()
    t.join()
    np.testing.assert_array_equal(a, out[0])


def test_save_png_round_trips_and_leaves_no_temp_file(tmp_path, renderer):
    img = renderer.render()
    p = save_png(img, tmp_path / "sub" / "face.png")
    np.testing.assert_array_equal(np.asarray(Image.open(p)), img)
    assert os.listdir(tmp_path / "sub") == ["face.png"]


def test_contact_sheet_lays_out_labelled_tiles():
    tiles = [np.full((60, 80, 3), 40 * i, np.uint8) for i in range(5)]
    sheet = contact_sheet(tiles, [f"AU{i:02d}" for i in range(5)], columns=3, title="t")
    assert sheet.shape[1] >= 3 * 80 and sheet.shape[0] >= 2 * 60
    assert sheet.std() > 10
    with pytest.raises(ParameterError):
        contact_sheet([], [])


def test_missing_egl_is_a_render_error_with_the_fix(monkeypatch, builtin_rig):
    import mimika.render.context as context

    def boom():
        raise RuntimeError("eglGetDisplay failed")

    monkeypatch.setattr(context, "_context", None)
    monkeypatch.setattr(context, "_create_context", boom)
    with pytest.raises(RenderError, match="apt-get install -y libegl1 libgl1-mesa-dri"):
        Renderer(builtin_rig.head, size=(32, 32)).render()


def _sheet(z: float, n: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat square sheet at depth ``z`` (vertices, faces, uvs) facing the camera."""
    xs = np.linspace(-6, 6, n)
    x, y = np.meshgrid(xs, xs)
    v = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], 1)
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([a, d, c], 1)])
    return v, faces, (v[:, :2] + 6) / 12


@pytest.mark.parametrize("material", ["eyebrow", "eyelash"])
def test_fine_hairs_on_the_skin_let_it_show_through(material):
    """Brow and lash textures are blended with their own alpha (hairs lying on the skin): a
    texel 60 % covered by dark hairs shows 40 % of the skin under it, not an opaque band
    (blended hair parts draw an opaque core wherever alpha reaches 0.5)."""
    from mimika.face.head import Head, MeshObject, Part, Texture

    v, f, _ = _sheet(10.0, 9)
    skin = MeshObject("skin", "body", v, (Part("sclera", f),), oriented=True)
    v2, f2, uv2 = _sheet(10.2)
    shade = {}
    for cover in (0, 153, 255):
        tex = np.zeros((8, 8, 4), np.uint8)
        tex[..., 3] = cover
        hairs = MeshObject("hairs", "body", v2, (Part(material, f2, Texture(tex), "blend"),),
                           uvs=uv2, oriented=True)
        head = Head("sheet", (skin, hairs), landmarks=np.arange(68),
                    anchors={"eye_L": [3.0, 0.0, 10.0], "eye_R": [-3.0, 0.0, 10.0]})
        with Renderer(head, size=(64, 64), samples=0) as r:
            shade[cover] = r.render().astype(float)[32, 32].mean()
    assert shade[255] < 0.2 * shade[0]  # fully covered: the hairs' dark colour
    assert 0.3 < shade[153] / shade[0] < 0.6  # 60 % covered: 40 % skin


def test_the_portrait_keeps_a_dropped_jaw_in_the_picture_and_a_close_up_is_larger(builtin_rig):
    head = builtin_rig.head
    lm = head.landmark_points(builtin_rig.deform({"AU26": 1.0, "AU27": 1.0}))
    with Renderer(head, size=SIZE) as r, Renderer(head, size=SIZE, fill=0.75) as close:
        chin = r.camera("front").project(lm[[8]], SIZE)[0]
        eyes = [c.camera("front").project(head.landmark_points()[[36, 45]], SIZE)
                for c in (r, close)]
    assert chin[1] < 0.95 * SIZE[1]  # the chin of the widest-open mouth stays inside
    iod = [float(np.linalg.norm(e[1] - e[0])) for e in eyes]
    assert iod[1] / iod[0] == pytest.approx(0.75 / 0.6, rel=0.05)
    with pytest.raises(ParameterError, match="fill"):
        Renderer(head, size=SIZE, fill=1.5)


def test_hair_highlights_follow_the_strands_of_a_flow_map():
    """A hair part's flow map sets the direction its strand highlights run across: strands
    painted hanging down (the flow pointing down the sheet) shine as hair without a map does
    (strands along world down), strands combed sideways shine differently — on a head, hair
    combed back no longer draws light streaks along the edges of its cards."""
    from mimika.face.head import Head, MeshObject, Part, Texture

    v0, f0, _ = _sheet(10.0, 9)
    skin = MeshObject("skin", "body", v0, (Part("sclera", f0),), oriented=True)
    v, f, uv = _sheet(10.2, 9)
    hair = np.zeros((8, 8, 4), np.uint8)
    hair[...] = (60, 40, 30, 255)
    shine = {}
    for name, ab in (("none", None), ("down", (0.0, -1.0)), ("sideways", (1.0, 0.0))):
        flow = None if ab is None else np.tile(
            np.round([127.5 + 127.5 * ab[0], 127.5 + 127.5 * ab[1], 255]).astype(np.uint8),
            (8, 8, 1))
        sheet = MeshObject("hair", "face", v, (Part("hair", f, Texture(hair, flow=flow),
                                                    "blend"),), uvs=uv, oriented=True)
        head = Head("sheet", (skin, sheet), landmarks=np.arange(68),
                    anchors={"eye_L": [3.0, 0.0, 10.0], "eye_R": [-3.0, 0.0, 10.0]})
        with Renderer(head, size=(64, 64), samples=0) as r:
            shine[name] = r.render().astype(float)[16:48, 16:48].mean(2)
    assert np.abs(shine["down"] - shine["none"]).mean() < 2.0
    assert np.abs(shine["sideways"] - shine["none"]).mean() > 10.0
