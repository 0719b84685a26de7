// Skin detail (DETAIL): a tangent-space normal map of the fine relief — pores, a millimetre
// grain, fine lines (RGB; +x along u, +y along v) — and a roughness scale (A: 0.5 + a) at the
// part's UVs, painted once per character (face/makehuman/paint/skin.py). The tangent frame
// comes from the screen derivatives of position and UVs (Schüler's cotangent frame, as
// three.js builds it for a glTF without tangents), so the mesh needs no tangents.
uniform sampler2D u_detail;

vec3 detail_normal(vec3 n, vec3 p, vec2 uv, out float rough) {
    vec4 t = texture(u_detail, uv);
    rough = 0.5 + t.a;
    vec3 m = t.rgb * 2.0 - 1.0;
    vec3 dp1 = dFdx(p), dp2 = dFdy(p);
    vec2 duv1 = dFdx(uv), duv2 = dFdy(uv);
    vec3 dp2perp = cross(dp2, n), dp1perp = cross(n, dp1);
    vec3 tu = dp2perp * duv1.x + dp1perp * duv2.x;
    vec3 tv = dp2perp * duv1.y + dp1perp * duv2.y;
    float s = inversesqrt(max(max(dot(tu, tu), dot(tv, tv)), 1e-30));
    return normalize(s * (m.x * tu + m.y * tv) + m.z * n);
}
