"""The mouth as an observer sees it: teeth seated behind the lips as in a real mouth (an open
smile shows the upper teeth, not both rows edge to edge) and lips that part cleanly."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from tests.conftest import needs_makehuman

pytestmark = needs_makehuman
SMILE = {"AU06": 1.0, "AU12": 1.0, "AU25": 1.0}


def _incisors(head, rig):
    """Masks over the teeth object's vertices: the upper and lower front incisors at the
    midline (tooth parts only: not the gums)."""
    o = head["teeth"]
    tooth = np.zeros(o.n_vertices, bool)
    tooth[np.concatenate([p.faces.ravel() for p in o.parts if p.material == "teeth"])] = True
    teeth = o.vertices
    lower = np.linalg.norm(rig.deform({"AU27": 1.0})["teeth"] - teeth, axis=1) > 0.1
    skin, lm = head["skin"].vertices, head.landmarks
    mid = tooth & (np.abs(teeth[:, 0] - skin[lm[[48, 54]], 0].mean()) < 0.4) & (
        np.abs(teeth[:, 1] - skin[lm[[62, 66]], 1].mean()) < 1.5)
    return [row & (teeth[:, 2] > teeth[row, 2].max() - 0.3)
            for row in (mid & ~lower, mid & lower)]


@pytest.mark.parametrize("name", ["amara", "daniel", "mei", "tomas"])
def test_an_open_smile_shows_the_upper_teeth_and_hides_the_lower(name):
    """As on the ICT Face Model's scan of an actor (upper teeth fill 0.74 of the opening,
    the lower edge 0.3 mm above the lip); MakeHuman's own dentition showed 0.29-0.35 and
    2.6-4.1 mm of the lower teeth: a clenched grimace."""
    from mimika.face.heads import load_head

    head, rig = load_head(name)
    up, lo = _incisors(head, rig)
    lm = head.landmarks
    rest = head["skin"].vertices  # lips pressed together: seated against them once parted
    if rig.release:
        rest = rest + rig.release_deltas()["skin"]
    assert rest[lm[62], 1] - head["teeth"].vertices[up, 1].min() == pytest.approx(0.21, abs=0.02)
    pos = rig.deform(SMILE)
    ul, ll = pos["skin"][lm[62], 1], pos["skin"][lm[66], 1]
    shown = (ul - pos["teeth"][up, 1].min()) / (ul - ll)
    assert 0.55 < shown < 0.9
    assert pos["teeth"][lo, 1].max() - ll < 0.15  # the lower incisors stay behind the lip


@pytest.mark.parametrize("name", ["amara", "mei"])
def test_a_dropped_jaw_keeps_the_lower_lip_over_the_lower_teeth(name):
    """ICT's actor at AU26 and AU27: the lower incisors' edge 0.1 and 0.5 mm above the lower
    lip, the lips as far apart as the teeth. MakeHuman's jawOpen dropped the lip a quarter
    further than the teeth: 4 and 7 mm of the lower row bared under a wide-open mouth."""
    from mimika.face.heads import load_head

    head, rig = load_head(name)
    up, lo = _incisors(head, rig)
    lm = head.landmarks
    for au in ("AU26", "AU27"):
        pos = rig.deform({au: 1.0})
        bared = pos["teeth"][lo, 1].max() - pos["skin"][lm[66], 1]
        assert bared < 0.1, au  # cm
        teeth = pos["teeth"][up, 1].min() - pos["teeth"][lo, 1].max()
        lips = pos["skin"][lm[62], 1] - pos["skin"][lm[66], 1]
        assert lips < teeth + 0.35, au


def _upper_lip(head) -> np.ndarray:
    """Skin vertices nearer (along the skin) to the upper lip's outer middle (landmark 51)
    than to the lower's (57) and within 2 cm of the mouth."""
    o = head["skin"]
    v, f = o.vertices.astype(float), o.faces
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    g = coo_matrix((np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1) + 1e-9, (e[:, 0], e[:, 1])),
                   shape=(len(v), len(v))).tocsr()
    d51, d57 = dijkstra(g, directed=False, indices=head.landmarks[[51, 57]])
    return (d51 < d57) & (d51 < 2.0)


@pytest.mark.parametrize("aus", [{"AU16": 0.8, "AU25": 0.8}, {"AU10": 1.0, "AU25": 1.0},
                                 {"AU11": 1.0}])
def test_parting_lips_leave_no_flap_over_the_front_teeth(character_rig, aus):
    """No part of the upper lip's inner face is dragged along with the lower lip: it hung
    6-9 mm into the opening in front of the incisors as a dark flap ('missing teeth')."""
    rig = character_rig
    head = rig.head
    upper, lm = _upper_lip(head), head.landmarks
    up, _ = _incisors(head, rig)
    pos = rig.deform(aus)
    skin = pos["skin"]
    front = upper & (np.abs(skin[:, 0] - skin[lm[62], 0]) < 0.5) & (
        skin[:, 2] > pos["teeth"][up, 2].max() - 0.05)
    hang = skin[lm[62], 1] - skin[front, 1].min()
    assert hang < 0.4, f"{aus}: the upper lip hangs {10 * hang:.1f} mm over the teeth"


@pytest.mark.parametrize("name", ["amara", "daniel", "mei", "tomas"])
def test_a_relaxed_mouth_is_closed_and_au25_parts_it(name):
    """At rest the inner lip edges meet (MakeHuman left amara's 2.4-3.0 mm apart, the teeth
    showing between them: her neutral face read "surprised" to face-api); AU25 parts them."""
    from mimika.face.heads import load_head

    head, rig = load_head(name)
    lm = head.landmarks

    def gap(skin):  # mean vertical distance of the inner lip edges, 61-63 over 67-65, in mm
        return 10 * float(np.mean(skin[lm[[61, 62, 63]], 1] - skin[lm[[67, 66, 65]], 1]))

    assert abs(gap(head["skin"].vertices)) < 0.5
    assert gap(rig.deform({"AU25": 1.0})["skin"]) > 4.0


@pytest.mark.parametrize("name", ["amara", "daniel", "mei", "tomas"])
def test_the_nose_wrinkler_raises_the_upper_lip_off_the_lower(name):
    """AU09 lifts the upper lip and leaves the lower one (ICT's actor: 7.9 and 0.9 % of the
    eye distance; the lips part 10.8 %). Half of a character's AU09 is ICT's sneer carried
    on as one field over both lips: it lifted the lower lip as far, and disgust (9+17) was
    a closed pout that read "angry". Now the lower lip stays and the lips part."""
    from mimika.face.calibration import inter_ocular, lip_opening
    from mimika.face.heads import load_head

    head, rig = load_head(name)
    lm, iod = head.landmarks, inter_ocular(head)
    dy = (rig.deform({"AU09": 1.0})["skin"] - head["skin"].vertices)[:, 1] / iod
    assert dy[lm[62]] > 0.05 and abs(dy[lm[66]]) < 0.35 * dy[lm[62]]
    assert lip_opening(rig, {"AU09": 1.0}) > 0.05


def test_lips_close_at_p_b_m_in_a_disgusted_face():
    """AU09 now parts the lips (above), so a bilabial relaxes it as it does AU10: a
    disgusted speaker still closes the lips at every /p b m/, the nose wrinkled between."""
    pytest.importorskip("espeakng_loader")
    from mimika.face.calibration import lip_opening
    from mimika.face.heads import load_head
    from mimika.speech import bilabial_apex_times, combine, mouth_track, synthesize
    from mimika.tracks import AUTrack

    u = synthesize("Bob, Pam and Mum bought a bumper box.", lang="en", engine="espeak")
    tr = combine(mouth_track(u, fps=25), AUTrack.constant({"AU09": 1.0, "AU17": 0.8}, fps=25))
    _, rig = load_head("daniel")
    apex = bilabial_apex_times(u)
    assert len(apex) >= 6
    assert max(lip_opening(rig, tr.frame(round(t * 25))) for t in apex) == 0.0
    assert np.median(tr["AU09"]) > 0.8  # the nose stays wrinkled between them


@pytest.mark.parametrize("name", ["amara", "daniel", "tomas"])
def test_lips_pressed_together_at_rest_part_as_soon_as_an_au_parts_them(name):
    """Seen from the front, AU25 at B and a /t/ open the lips as a real mouth does (ICT's
    scan: 6.3 and 9.6 % IOD); the rest pose's seal had kept amara's closed at AU25 0.36 and
    her /t/ at 3 % IOD. A trace (0.1) still leaves them closed."""
    from mimika.face.calibration import lip_opening
    from mimika.face.heads import load_head

    _, rig = load_head(name)
    alveolar = {"AU20": 0.05, "AU25": 0.35, "AU26": 0.12}
    assert lip_opening(rig, {}) == 0.0
    assert lip_opening(rig, {"AU25": 0.1}) < 0.01
    assert lip_opening(rig, {"AU25": 0.36}) > 0.045
    assert lip_opening(rig, alveolar) > 0.07


def test_the_default_character_speaks_with_parted_lips_and_closes_them_at_p_b_m():
    """Lip-sync on the newsreader's own face: lips shut at every /p b m/ apex (seen from the
    front) and stand apart between them as a real mouth's do (median over the words 12.6 %
    of the eye distance; 6.6 % while the rest pose's seal held them together)."""
    pytest.importorskip("espeakng_loader")
    from mimika.face.calibration import lip_opening
    from mimika.face.heads import DEFAULT_HEAD, load_head
    from mimika.speech import bilabial_apex_times, mouth_track, synthesize

    u = synthesize("Bob, Pam and Mum bought a bumper box of bubble gum. Maybe a big map, "
                   "please.", lang="en", engine="espeak")
    tr = mouth_track(u, fps=25)
    _, rig = load_head(DEFAULT_HEAD)
    apex = bilabial_apex_times(u)
    assert len(apex) >= 8
    assert max(lip_opening(rig, tr.frame(round(t * 25))) for t in apex) == 0.0
    words = [k for k in range(tr.n_frames) if any(w.start <= k / 25 <= w.end for w in u.words)]
    assert np.median([lip_opening(rig, tr.frame(k)) for k in words[::2]]) > 0.09


def test_lengthened_incisors_keep_square_biting_corners():
    """The crowns are stretched to a real length, but each incisor's biting end keeps
    MakeHuman's shape: stretched with the rest, the corners it cuts off grew into V-shaped
    gaps between the teeth that read as saw teeth when only the edges show (a smile at C)."""
    from mimika.face.makehuman.build import Outfit, build
    from mimika.face.makehuman.character_file import load_character_spec
    from mimika.face.makehuman.paint.regions import uv_islands
    from mimika.face.makehuman.teeth import _front, _on_gum, rows, seat_teeth

    c = load_character_spec("amara")
    built = build(c.phenotype_values(), Outfit(c.hair, c.eyebrows, c.eyelashes, c.clothes))

    def corners(b) -> np.ndarray:
        """Per upper central incisor: how far above its edge it reaches its full width,
        over its half-width."""
        t = next(p for p in b.pieces if p.name == "teeth")
        v = t.vertices.astype(float)
        tris = np.concatenate(list(t.parts.values()))
        tooth = uv_islands(t.weld[tris], int(t.weld.max()) + 1)[t.weld]
        upper = ~rows(b) & ~_on_gum(t)
        out = []
        for i in np.unique(tooth[_front(b, v, upper)]):
            p = v[(tooth == i) & upper]
            half = 0.5 * np.ptp(p[:, 0])
            wide = np.abs(p[:, 0] - 0.5 * (p[:, 0].min() + p[:, 0].max())) >= 0.85 * half
            out.append((p[wide, 1].min() - p[:, 1].min()) / half)
        return np.array(out)

    before, after = corners(built), corners(seat_teeth(built))
    assert len(after) >= 2
    t0 = next(p for p in built.pieces if p.name == "teeth")
    t1 = next(p for p in seat_teeth(built).pieces if p.name == "teeth")
    assert np.ptp(t1.vertices[:, 1]) > np.ptp(t0.vertices[:, 1])  # the crowns did grow
    np.testing.assert_allclose(after, before, rtol=0.1)


def _opening(name: str, view: str, aus: dict) -> tuple[np.ndarray, np.ndarray]:
    """Luma of a render of ``name`` (480 × 480) and the mask of its lip opening (60-67)."""
    from mimika.face.heads import load_head
    from mimika.render import Renderer

    head, rig = load_head(name)
    size = (480, 480)
    pos = rig.deform(aus)
    with Renderer(rig.head, size=size) as r:
        img = r.render(pos, view=view, aus=aus).astype(float).mean(2)
        cam = r.camera(view)
    return img, cam.outline_mask(head.landmark_points(pos)[60:68], size)


@pytest.mark.render
@pytest.mark.parametrize("name", ["amara", "mei"])
def test_a_dropped_jaw_shows_the_dark_of_the_mouth_above_the_tongue(name):
    """Seen from the front, the upper half of an open mouth (AU26) is the dark of the mouth
    and the lower half the tongue behind the lower teeth, as in a photograph. MakeHuman's
    jawOpen left the tongue's back at the palate: a wall of tongue filled the opening (upper
    half 0.5-0.7 of the lower's luma)."""
    img, mouth = _opening(name, "front", {"AU26": 1.0})
    rows = np.nonzero(mouth)[0]
    upper = mouth & (np.arange(mouth.shape[0])[:, None] < np.median(rows))
    assert mouth.sum() > 800
    assert img[upper].mean() < 0.45 * img[mouth & ~upper].mean()


@pytest.mark.render
@pytest.mark.parametrize("name", ["amara", "mei"])
def test_the_inside_of_the_cheek_is_shaded_not_black(name):
    """Seen from three-quarter, an open mouth shows the inside of the near cheek beside the
    molars: mucosa in the light that comes through the opening. Outside the bounds the
    renderer drew around the lip contour it was unlit — 13-26 % of the opening pure black."""
    img, mouth = _opening(name, "three-quarter", {"AU26": 1.0})
    assert mouth.sum() > 800
    assert (img[mouth] < 6).mean() < 0.05
