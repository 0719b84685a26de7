"""What an observer sees of the character's eyes and skin: one catchlight per eye placed by the
key light, the lids' shade on the eyeball, the caruncle's pink in the inner corner; skin with
fine detail at 720p and glossier in the T-zone than on the cheeks; the GLB carries the detail."""

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

pytestmark = pytest.mark.render
LUMA = np.array([0.2126, 0.7152, 0.0722])


def _eye_mask(cam, points, size, erode=2):
    from PIL import Image, ImageDraw

    m = Image.new("L", size, 0)
    ImageDraw.Draw(m).polygon([tuple(p) for p in cam.project(points, size)], fill=1)
    return ndimage.binary_erosion(np.asarray(m, bool), iterations=erode)


def _iris(head, eye, cam, size):
    o = head[eye]
    ids = np.unique(np.concatenate([p.faces.ravel() for p in o.parts if p.material == "iris"]))
    pts = cam.project(o.vertices[ids], size)
    c = pts.mean(0)
    return c, float(np.linalg.norm(pts - c, axis=1).max())


def test_each_eye_has_one_dominant_catchlight_toward_the_key_light(character_rig):
    from mimika.render import Renderer

    head, size = character_rig.head, (480, 480)
    with Renderer(head, size=size, lighting="studio") as r:  # key high on the viewer's left
        lum = r.render().astype(float) @ LUMA
        cam = r.camera("front")
    lm = np.asarray(head.landmark_points(), float)
    yy, xx = np.mgrid[:size[1], :size[0]]
    for ids, eye in ((range(36, 42), "eye_R"), (range(42, 48), "eye_L")):
        c, rad = _iris(head, eye, cam, size)
        disc = _eye_mask(cam, lm[list(ids)], size) & (np.hypot(xx - c[0], yy - c[1]) < 0.8 * rad)
        y, x = np.unravel_index(np.argmax(np.where(disc, lum, -1)), lum.shape)
        assert x < c[0] and y < c[1], eye  # up and to the viewer's left, as the key
        rest = disc & (np.hypot(xx - x, yy - y) > 7)
        base = np.median(lum[disc])
        assert lum[y, x] - base > 120, eye
        assert lum[rest].max() - base < 0.4 * (lum[y, x] - base), eye  # the fill's is faint


def _eye_zoom(head, light="studio"):
    from mimika.render import Renderer
    from mimika.render.camera import Camera

    lm = np.asarray(head.landmark_points(), float)
    c = lm[42:48].mean(0)
    cam = Camera(eye=c + np.array([0.0, 0.0, 60.0]), target=c, up=np.array([0.0, 1.0, 0.0]),
                 fov_y=4.0, aspect=1.5, near=20.0, far=120.0)
    size = (480, 320)
    with Renderer(head, size=size, lighting=light) as r:
        img = r.render(None, camera=cam).astype(float)
    return img, cam, size, _eye_mask(cam, lm[42:48], size, erode=3)


def test_the_eyeball_is_darker_under_the_upper_lid_and_pink_in_the_inner_corner(
        character_rig):
    head = character_rig.head
    img, cam, size, mask = _eye_zoom(head)
    lum = img @ LUMA
    c, rad = _iris(head, "eye_L", cam, size)
    cols = np.nonzero(mask.any(0))[0]
    tops, mids = [], []
    for col in range(int(c[0] + rad) + 4, cols[-1] - 4, 4):  # the sclera toward the outer corner
        rows = np.nonzero(mask[:, col])[0]
        if len(rows) >= 8:
            n = len(rows)
            tops.append(lum[rows[: n // 4], col].mean())
            mids.append(lum[rows[3 * n // 8: 5 * n // 8], col].mean())
    assert len(tops) >= 2 and np.mean(tops) < 0.95 * np.mean(mids)
    # the inner corner (the eye_L's nose side: toward the image's left) is pinker than the
    # sclera by the outer corner
    inner = mask & (np.arange(size[0]) < cols[0] + 0.08 * (cols[-1] - cols[0]))[None, :]
    outer = mask & (np.arange(size[0]) > c[0] + rad + 4)[None, :]
    red = img[..., 0] / np.maximum(img[..., 1], 1.0)
    assert red[inner].mean() > red[outer].mean() + 0.08


def _without_detail(head):
    objs = []
    for o in head.objects:
        parts = tuple(replace(p, texture=replace(p.texture, normal=None))
                      if p.texture is not None and p.texture.normal is not None else p
                      for p in o.parts)
        objs.append(replace(o, parts=parts))
    return replace(head, objects=tuple(objs))


def test_skin_has_fine_detail_in_a_720p_news_frame(character_rig):
    from mimika.newsreader.pipeline import news_camera
    from mimika.render import Renderer
    from mimika.render.lighting import parse_light
    from mimika.render.skin import SkinParams

    head = character_rig.head
    assert any(p.texture is not None and p.texture.normal is not None
               for p in head[head.landmark_object].parts)
    cam = news_camera(head, "front", 16 / 9)
    lm = np.asarray(head.landmark_points(), float)
    cheeks = [0.35 * lm[k] + 0.35 * lm[n] + 0.3 * lm[e] + [0, -0.3, 0.4]
              for k, n, e in ((2, 31, 41), (14, 35, 46))]
    fine = []
    for h in (head, _without_detail(head)):
        with Renderer(h, size=(1280, 720), samples=0, skin_shader=SkinParams(),
                      lighting=parse_light(None, "news"), crop=True) as r:
            lum = r.render(None, camera=cam).astype(float) @ LUMA
        high = lum - ndimage.gaussian_filter(lum, 2.0)  # detail a few pixels across
        xy = np.round(cam.project(np.array(cheeks), (1280, 720))).astype(int)
        fine.append(np.mean([high[y - 8:y + 8, x - 8:x + 8].std() for x, y in xy]))
    assert fine[0] > 1.2 * fine[1], fine


def test_the_skin_detail_is_glossier_on_nose_and_lips_than_on_the_cheeks(character_rig):
    head = character_rig.head
    skin = head[head.landmark_object]
    tex = next(p.texture for p in skin.parts if p.material == "skin")
    h, w = tex.normal.shape[:2]
    lm = np.asarray(head.landmark_points(), float)

    def rough(point):  # the detail map's roughness scale at the skin vertex nearest point
        i = int(np.argmin(np.linalg.norm(skin.vertices - point, axis=1)))
        u, v = skin.uvs[i]
        return 0.5 + tex.normal[int((1 - v) * h), int(u * w), 3] / 255.0

    cheek = 0.35 * lm[2] + 0.35 * lm[31] + 0.3 * lm[41] + [0, -0.3, 0.4]
    assert rough(lm[30]) < rough(cheek) - 0.15  # the nose tip
    assert rough((lm[51] + lm[62]) / 2) < rough(cheek) - 0.15  # the upper lip
    n = tex.normal[..., :3].astype(float) / 127.5 - 1.0
    assert np.abs(n[..., :2]).max() > 0.2 and (n[..., 2] > 0).all()  # relief, facing out


def test_the_character_glb_carries_the_skin_normal_and_roughness_maps(character_rig):
    from mimika.io.gltf_skinned import build_skinned_gltf

    doc, _ = build_skinned_gltf(character_rig)
    skin = next(m for m in doc["materials"] if m["name"] == "skin")
    assert "normalTexture" in skin and "metallicRoughnessTexture" in skin["pbrMetallicRoughness"]
    assert 0 < skin["pbrMetallicRoughness"]["roughnessFactor"] <= 1
    names = {doc["images"][doc["textures"][skin["normalTexture"]["index"]]["source"]]["name"]}
    assert names == {"skin_normal"}
