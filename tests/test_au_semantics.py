"""Each of seed 002's 32 AUs moves the expected region in the expected direction — on both
heads — and leaves far regions alone. Measured on the 68 Multi-PIE landmarks (cm)."""

import numpy as np
import pytest

from mimika.facs import SEED_AUS

# Multi-PIE landmark ids (subject's right = −x side first)
BROW_OUT, BROW_MID, BROW_IN = [17, 26], [19, 24], [21, 22]
UPPER_LID, LOWER_LID = [37, 38, 43, 44], [40, 41, 46, 47]
NOSE_TIP, NOSTRIL_WINGS, CHIN = 30, [31, 35], 8
CORNER_R, CORNER_L = 48, 54
UPPER_LIP, LOWER_LIP = [50, 51, 52], [56, 57, 58]
IN_UP, IN_LO = 62, 66
UPPER_FACE = {"AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU43"}
LOWER_FACE = {"AU10", "AU12", "AU15", "AU16", "AU17", "AU18", "AU20", "AU22", "AU23", "AU24",
              "AU25", "AU26", "AU27", "AU28"}


def landmarks(rig, aus):
    pos = rig.deform(aus)
    return rig.head.landmark_points(pos), pos


def lip_gap(L):
    return L[IN_LO, 1] - L[IN_UP, 1]  # negative when open (lower below upper)


def lip_height(L):
    return (L[51, 1] - L[IN_UP, 1]) + (L[IN_LO, 1] - L[57, 1])


def iris_centre(rig, pos, name):
    obj = rig.head[name]
    idx = np.unique(np.concatenate([p.faces.ravel() for p in obj.parts
                                    if p.material in ("iris", "pupil")]))
    return pos[name][idx].mean(0)


def lower_teeth_y(rig, pos):
    objs = [o for o in rig.head.objects if o.category == "teeth"]
    rest = np.concatenate([o.vertices for o in objs])
    now = np.concatenate([pos[o.name] for o in objs])
    low = rest[:, 1] < np.quantile(rest[:, 1], 0.3)
    return now[low, 1].mean() - rest[low, 1].mean()


MIN = 0.08  # cm: the least movement that counts as "moves"


def check(code, rig):
    L0, rest = landmarks(rig, {})
    L, pos = landmarks(rig, {code: 1.0})
    d = L - L0
    dy, dx, dz = d[:, 1], d[:, 0], d[:, 2]
    match code:
        case "AU01":
            assert dy[BROW_IN].min() > MIN and dy[BROW_IN].mean() > dy[BROW_OUT].mean()
        case "AU02":
            assert dy[BROW_OUT].min() > MIN and dy[BROW_OUT].mean() > dy[BROW_IN].mean()
        case "AU04":
            assert dy[BROW_MID].max() < -MIN
            assert abs(L[22, 0] - L[21, 0]) < abs(L0[22, 0] - L0[21, 0]) - 0.05
        case "AU05":
            assert dy[UPPER_LID].min() > MIN / 2
        case "AU06":
            assert dy[LOWER_LID].min() > MIN / 2
        case "AU07":
            assert dy[LOWER_LID].min() > MIN / 2
        case "AU09":
            assert dy[NOSTRIL_WINGS].min() > MIN
        case "AU10":
            assert dy[UPPER_LIP].min() > MIN and dy[UPPER_LIP].mean() > dy[LOWER_LIP].mean() + MIN
        case "AU12":
            assert dy[[CORNER_R, CORNER_L]].min() > MIN
            assert dx[CORNER_L] > MIN and dx[CORNER_R] < -MIN
        case "AU15":
            assert dy[[CORNER_R, CORNER_L]].max() < -MIN
        case "AU16":
            assert dy[LOWER_LIP].max() < -MIN and dy[LOWER_LIP].mean() < dy[UPPER_LIP].mean()
        case "AU17":
            assert dy[[CHIN, 57]].min() > MIN / 2
        case "AU18":
            assert dx[CORNER_L] < -MIN and dx[CORNER_R] > MIN
            assert dz[[51, 57]].min() > 0
        case "AU20":
            assert dx[CORNER_L] > MIN and dx[CORNER_R] < -MIN
            width0, width = L0[CORNER_L, 0] - L0[CORNER_R, 0], L[CORNER_L, 0] - L[CORNER_R, 0]
            assert width > width0 + 2 * MIN
        case "AU22":
            assert dz[[51, 57]].min() > MIN / 2
            assert lip_gap(L) < lip_gap(L0)
        case "AU23" | "AU24":
            assert lip_height(L) < lip_height(L0) - MIN / 2
        case "AU25":
            assert lip_gap(L) < lip_gap(L0) - 2 * MIN
        case "AU26" | "AU27":
            assert lip_gap(L) < lip_gap(L0) - 2 * MIN
            assert dy[CHIN] < -MIN and lower_teeth_y(rig, pos) < -MIN
            if code == "AU27":
                L26, p26 = landmarks(rig, {"AU26": 1.0})
                assert lip_gap(L) < lip_gap(L26) and lower_teeth_y(rig, pos) < lower_teeth_y(
                    rig, p26)
        case "AU28":
            assert lip_height(L) < lip_height(L0) - MIN / 2
        case "AU43":
            gap0 = (L0[[37, 38, 43, 44], 1] - L0[[41, 40, 47, 46], 1]).mean()
            gap = (L[[37, 38, 43, 44], 1] - L[[41, 40, 47, 46], 1])
            assert gap0 > 0.4 and np.all(gap < 0.12 * gap0)
        case "AU51" | "AU52":
            assert dx[NOSE_TIP] * (1 if code == "AU51" else -1) > 1.0
        case "AU53" | "AU54":
            assert dy[NOSE_TIP] * (1 if code == "AU53" else -1) > 1.0
        case "AU55" | "AU56":
            skin0, skin = rest["skin"], pos["skin"]
            top = np.argmax(skin0[:, 1])
            assert (skin[top, 0] - skin0[top, 0]) * (1 if code == "AU55" else -1) > 1.0
        case "AU61" | "AU62" | "AU63" | "AU64":
            axis, sign = {"AU61": (0, 1), "AU62": (0, -1), "AU63": (1, 1), "AU64": (1, -1)}[code]
            for eye in ("eye_L", "eye_R"):
                move = iris_centre(rig, pos, eye) - iris_centre(rig, rest, eye)
                assert move[axis] * sign > 0.2
            np.testing.assert_allclose(pos["skin"][rig.head.landmarks[[30, 8]]],
                                       rest["skin"][rig.head.landmarks[[30, 8]]], atol=1e-4)
        case _:
            pytest.fail(f"no expectation written for {code}")
    # nothing far away moves
    if code in UPPER_FACE:
        assert np.abs(d[[CHIN, 57]]).max() < 0.05
    if code in LOWER_FACE:
        assert np.abs(d[BROW_MID + BROW_OUT]).max() < 0.05
    if code in UPPER_FACE | LOWER_FACE:
        skin0, skin = rest["skin"], pos["skin"]
        back = skin0[:, 2] < 0  # back of the skull and neck
        assert np.abs(skin[back] - skin0[back]).max() < 0.02


@pytest.mark.parametrize("code", SEED_AUS)
def test_seed_au_moves_expected_region(any_rig, code):
    check(code, any_rig)


@pytest.mark.parametrize("code", ["AU01", "AU12", "AU15", "AU43"])
def test_unilateral_variant_moves_only_its_side(any_rig, code):
    L0, _ = landmarks(any_rig, {})
    d = {s: np.abs(landmarks(any_rig, {code + s: 1.0})[0] - L0).max(1) for s in "LR"}
    left = L0[:, 0] > 1.5  # subject's left half (+x), away from the midline
    right = L0[:, 0] < -1.5
    # the other side may follow a little (skin is connected: a one-sided smile pulls the
    # whole upper lip), by under 10 % of the motion (ICT < 5 %, MakeHuman faceunits ≈ 8 %)
    assert d["L"][left].max() > MIN / 2 and d["L"][right].max() < 0.1 * d["L"][left].max()
    assert d["R"][right].max() > MIN / 2 and d["R"][left].max() < 0.1 * d["R"][right].max()
