// The texture's frame on a surface (DETAIL, FLOW): the gradients of u and v at a pixel, from
// the screen derivatives of position and UVs (Schüler's cotangent frame, as three.js builds
// it for a glTF without tangents), so the mesh needs no tangents. Scaled together: the
// longer of the two is unit length.
void uv_frame(vec3 n, vec3 p, vec2 uv, out vec3 gu, out vec3 gv) {
    vec3 dp1 = dFdx(p), dp2 = dFdy(p);
    vec2 duv1 = dFdx(uv), duv2 = dFdy(uv);
    vec3 dp2perp = cross(dp2, n), dp1perp = cross(n, dp1);
    gu = dp2perp * duv1.x + dp1perp * duv2.x;
    gv = dp2perp * duv1.y + dp1perp * duv2.y;
    float s = inversesqrt(max(max(dot(gu, gu), dot(gv, gv)), 1e-30));
    gu *= s;
    gv *= s;
}
