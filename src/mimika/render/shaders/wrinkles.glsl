// FACS appearance changes: the furrows, lines, bulges and dimpling that AUs bring to the skin
// (forehead lines of AU1/2, glabellar furrows of AU4, crow's feet and the infraorbital
// furrow of AU6/7, nose wrinkles of AU9, the nasolabial furrow of AU9/10/11/12, lip lines of
// AU18/22/23/24, the chin boss of AU17, the dimples of AU14, the folds of AU15/20).
//
// v_face: the fragment's place in face units (x toward the subject's left, y up, in
// inter-ocular distances from the eye midpoint; z = 1 on the face, 0 elsewhere). u_wr holds
// each group's depth in cm per side (left, right), AU intensity × depth × age; the landmarks
// come in face units with x ≥ 0 (the left half, mirrored). The height h (cm, < 0 in a
// furrow) bends the normal (Mikkelsen's surface gradient, from h's analytic face-space
// gradient taken by forward differences) and darkens furrow floors (cavity).
//
// llvmpipe runs every branch of a shader, taken or not, so a part of the face is drawn with
// only the groups that reach it compiled in: WR_GROUPS has bit k set for group k (default:
// all). WR_HIT(bits), empty by default, marks where a group's branch is entered: the pass
// that finds which groups reach which triangles (render/renderer.py) records it.
#ifndef WR_GROUPS
#define WR_GROUPS 16383
#endif
#ifndef WR_HIT
#define WR_HIT(bits)
#endif
in vec3 v_face;

uniform float u_wr[28];
uniform float u_brow_y;     // brow line
uniform vec2 u_eye_out;     // outer eye corner
uniform vec2 u_eye_in;      // inner eye corner
uniform float u_lid_y;      // lower lid
uniform vec2 u_wing;        // nose wing (alar base)
uniform float u_nasion_y;
uniform vec2 u_corner;      // mouth corner
uniform float u_lip_top;    // upper lip's top (vermilion border)
uniform float u_lip_bot;    // lower lip's bottom
uniform float u_chin_y;

float furrow(float d, float w) { return -exp(-d * d / (w * w)); }

float band(float y, float lo, float hi, float soft) {
    return smoothstep(lo - soft, lo + soft, y) * (1.0 - smoothstep(hi - soft, hi + soft, y));
}

float gw(int g, float x) {  // group g's depth on this side
    return mix(u_wr[2 * g + 1], u_wr[2 * g], smoothstep(-0.04, 0.04, x));
}

float wrinkle_height(vec2 f) {
    float x = f.x, y = f.y, ax = abs(x);
    float h = 0.0;
    // 0, 1: forehead lines (AU1 medial, AU2 lateral): horizontal, arched with the brows
    // each group only where it lies and has depth (llvmpipe skips a branch no pixel of a
    // block takes)
#if (WR_GROUPS & 3) != 0
    float fy = band(y, u_brow_y + 0.12, u_brow_y + 0.8, 0.06);
    if (fy > 0.0 && gw(0, x) + gw(1, x) > 0.0) {
        WR_HIT(3);
        float lines = 0.0;
        for (int k = 0; k < 4; k++) {
            float yk = u_brow_y + 0.2 + 0.135 * float(k) + 0.1 * ax * ax
                       + 0.012 * sin(9.0 * ax + 1.7 * float(k));
            lines += furrow(y - yk, 0.02) * (1.0 - 0.18 * float(k));
        }
        h += fy * lines * (gw(0, x) * exp(-ax * ax / 0.12) + gw(1, x)
                           * exp(-(ax - 0.5) * (ax - 0.5) / 0.09));
    }
#endif
    // 2: glabellar furrows (AU4): vertical, slightly oblique, between the inner brows
#if (WR_GROUPS & 4) != 0
    float gy = band(y, u_brow_y - 0.22, u_brow_y + 0.22, 0.06);
    if (gy > 0.0 && ax < 0.4 && gw(2, x) > 0.0) {
        WR_HIT(4);
        h += gw(2, x) * gy * (furrow(ax - 0.07 - 0.12 * (y - u_brow_y), 0.018)
                              + 0.6 * furrow(ax - 0.14 - 0.2 * (y - u_brow_y), 0.016));
    }
#endif
    // 3: the nasal root's horizontal line (AU4, AU9)
#if (WR_GROUPS & 8) != 0
    if (ax < 0.4 && abs(y - u_nasion_y) < 0.15 && gw(3, x) > 0.0) {
        WR_HIT(8);
        h += gw(3, x) * furrow(y - u_nasion_y - 0.03, 0.022) * exp(-ax * ax / 0.018);
    }
#endif
    // 4: crow's feet (AU6): lines fanning out from the outer eye corner
#if (WR_GROUPS & 16) != 0
    vec2 c = f - vec2(sign(x) * (u_eye_out.x + 0.04), u_eye_out.y);
    float r = length(c);
    if (ax > u_eye_out.x && r < 0.32 && gw(4, x) > 0.0) {
        WR_HIT(16);
        float th = atan(c.y, abs(c.x));
        float fan = 0.0;
        for (int k = 0; k < 4; k++) {
            fan += furrow((th - (-0.6 + 0.28 * float(k))) * r, 0.013);
        }
        h += gw(4, x) * fan * smoothstep(0.03, 0.08, r) * (1.0 - smoothstep(0.18, 0.3, r));
    }
#endif
    // 5: infraorbital furrow under the lower lid (AU6, AU7)
#if (WR_GROUPS & 32) != 0
    float ex = 0.5 * (u_eye_in.x + u_eye_out.x), ew = 0.5 * (u_eye_out.x - u_eye_in.x) + 0.1;
    float arc = u_lid_y - 0.11 - 0.25 * (ax - ex) * (ax - ex);
    if (abs(ax - ex) < ew && abs(y - arc) < 0.12 && gw(5, x) > 0.0) {
        WR_HIT(32);
        h += gw(5, x) * furrow(y - arc, 0.03) * (1.0 - smoothstep(ew - 0.06, ew, abs(ax - ex)));
    }
#endif
    // 6: nasolabial furrow (AU9, 10, 11, 12): from beside the nose wing to past the mouth
    // corner, the cheek bulging over it
#if (WR_GROUPS & 64) != 0
    float t = clamp((u_wing.y - y) / max(u_wing.y - u_corner.y + 0.12, 0.1), 0.0, 1.0);
    float xn = mix(u_wing.x + 0.07, u_corner.x + 0.08, t) + 0.05 * sin(3.1416 * t);
    float ny = band(y, u_corner.y - 0.14, u_wing.y + 0.02, 0.04);
    if (ny > 0.0 && abs(ax - xn) < 0.25 && gw(6, x) > 0.0) {
        WR_HIT(64);
    float taper = smoothstep(0.0, 0.12, t) * (1.0 - 0.55 * t);  // deepest beside the nose
    h += gw(6, x) * ny * taper
         * (furrow(ax - xn, 0.03) + 0.45 * exp(-pow((ax - xn - 0.075) / 0.05, 2.0)));
    }
#endif
    // 7: nose wrinkles (AU9): oblique lines across the bridge and its sides
#if (WR_GROUPS & 128) != 0
    float by = band(y, u_nasion_y - 0.35, u_nasion_y + 0.02, 0.04);
    if (by > 0.0 && ax < 0.26 && gw(7, x) > 0.0) {
        WR_HIT(128);
        float nl = 0.0;
        for (int k = 0; k < 4; k++) {
            nl += furrow(y - (u_nasion_y - 0.06 - 0.07 * float(k)) - 0.3 * ax, 0.014);
        }
        h += gw(7, x) * by * nl * (1.0 - smoothstep(0.18, 0.26, ax));
    }
#endif
    // 8: chin boss (AU17): dimpled skin over the chin, and 9: the mentolabial furrow
#if (WR_GROUPS & 256) != 0
    float cy = 0.5 * (u_lip_bot + u_chin_y);
    vec2 cc = vec2(x, y - cy) / vec2(0.3, 0.5 * (u_lip_bot - u_chin_y) + 0.02);
    float ce = exp(-dot(cc, cc) * 1.5);
    if (ce > 0.01 && gw(8, x) > 0.0) {
        WR_HIT(256);
        h += gw(8, x) * ce * (0.5 * sin(52.0 * x + 3.0 * sin(37.0 * y)) * sin(47.0 * y) - 0.3);
    }
#endif
#if (WR_GROUPS & 512) != 0
    if (ax < 0.6 && abs(y - u_lip_bot + 0.07) < 0.15 && gw(9, x) > 0.0) {
        WR_HIT(512);
        h += gw(9, x) * furrow(y - u_lip_bot + 0.07, 0.035) * exp(-ax * ax / 0.05);
    }
#endif
    // 10: vertical lip lines (AU18, 22, 23, 24), on the red of the lips
    float lx = 1.0 - smoothstep(u_corner.x - 0.12, u_corner.x, ax);
#if (WR_GROUPS & 1024) != 0
    float ly = band(y, u_lip_bot + 0.02, u_lip_top - 0.02, 0.02);
    float pitch = 0.038;
    if (ly * lx > 0.0 && gw(10, x) > 0.0) {
        WR_HIT(1024);
        float d = (fract(ax / pitch + 0.37 * sin(11.0 * y)) - 0.5) * pitch;
        h += gw(10, x) * ly * lx * furrow(d, 0.006);
    }
#endif
    // 11: perioral lines above the upper lip (AU18, 22, 24): radial, toward the mouth
#if (WR_GROUPS & 2048) != 0
    float py = band(y, u_lip_top, u_lip_top + 0.17, 0.03);
    if (py * lx > 0.0 && gw(11, x) > 0.0) {
        WR_HIT(2048);
        float dp = (fract(ax / 0.055 + 0.3 * (y - u_lip_top) / 0.17) - 0.5) * 0.055;
        h += gw(11, x) * py * lx * furrow(dp, 0.008);
    }
#endif
    // 12: dimple (AU14): a pit beside the mouth corner
#if (WR_GROUPS & 4096) != 0
    vec2 dc = vec2(ax - u_corner.x - 0.09, y - u_corner.y + 0.01);
    if (dot(dc, dc) < 0.02 && gw(12, x) > 0.0) {
        WR_HIT(4096);
        h += gw(12, x) * -exp(-dot(dc, dc) / 0.0016);
    }
#endif
    // 13: folds below and beside the corners (AU15, 20): oblique, down and out
#if (WR_GROUPS & 8192) != 0
    vec2 q = vec2(ax - u_corner.x - 0.02, y - u_corner.y + 0.03);
    vec2 dir = normalize(vec2(0.3, -1.0));
    float along = dot(q, dir);
    float across = q.x * dir.y - q.y * dir.x;
    if (abs(across) < 0.12 && along > -0.1 && along < 0.45 && gw(13, x) > 0.0) {
        WR_HIT(8192);
        h += gw(13, x) * furrow(across, 0.028) * band(along, 0.0, 0.32, 0.05);
    }
#endif
    return h;
}

// The normal bent by the wrinkles and a cavity factor (< 1 in furrows), at view-space
// position p with unit normal n.
const float WR_STEP = 0.004;  // face units (≈ 0.25 mm) of the forward differences

// The height at f and one step along x and along y.
vec3 wrinkle_heights(vec2 f) {
    return vec3(wrinkle_height(f), wrinkle_height(f + vec2(WR_STEP, 0.0)),
                wrinkle_height(f + vec2(0.0, WR_STEP)));
}

vec3 wrinkled_normal(vec3 n, vec3 p, out float cavity) {
    cavity = 1.0;
    if (v_face.z <= 0.0) return n;
    vec2 f = v_face.xy;
    vec3 hs = wrinkle_heights(f);
    float h0 = hs.x;
    float h = v_face.z * h0;
    vec2 g = v_face.z * vec2(hs.y - h0, hs.z - h0) / WR_STEP;
    cavity = clamp(1.0 + 3.0 * h, 0.55, 1.0);
    // Mikkelsen (2010): the height's screen derivatives from its face-space gradient
    float dhx = dot(g, dFdx(f)), dhy = dot(g, dFdy(f));
    vec3 sx = dFdx(p), sy = dFdy(p);
    vec3 r1 = cross(sy, n), r2 = cross(n, sx);
    float det = dot(sx, r1);
    vec3 grad = sign(det) * (dhx * r1 + dhy * r2);
    return normalize(abs(det) * n - grad);
}
