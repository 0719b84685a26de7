// The eye (mesh.frag.glsl's EYE: sclera, IRIS, CORNEA variants).
// * Wet surfaces reflect the studio: each light as a soft window-like box about its direction
//   (tall, reaching down to eye level: seen under lids that hide the top of the iris)
//   (the key's bright, the fill's a fourteenth as bright per unit of its light), the sky/ground
//   elsewhere, weighted by Fresnel (tear film, F0 0.025 × u_specular); u_shininess sets how
//   sharp the reflection is (cornea: sharp, sclera: blurred).
// * The lids shade the eyeball: its occlusion (render/occlusion.py lid_shade: low under the
//   upper lid and lashes, a little above the lower lid and in the corners) darkens the key
//   light and the reflections there.
// * The iris lies under the cornea: seen at an angle the view ray bends toward the eye's axis
//   (n = 1.376), so the iris point seen lies toward the viewer from the straight ray's (its
//   texture coordinates shift by the chamber's depth); the cornea focuses the key light onto
//   the iris's far side and the limbus shades its near side.
const float CATCH = 45.0;              // a light's box radiance per unit of the light's colour
const float FILL_CATCH = 0.07;         // the fill's box against the key's
const vec2 BOX = vec2(0.2, 0.45);      // box half size (tangent of the half angle), across × up
const float BOX_DROP = 0.25;           // the box's middle below its light (a tall softbox)
const float IOR = 1.376;               // cornea and aqueous humour
const float CHAMBER = 0.1;             // cornea to iris, in UV units (UV = eye-local x / 2R)
const float IRIS_R = 0.228;            // iris radius in UV units, less the limbal ring's edge

float lid_shade() {
    return mix(1.0, v_occ.x, u_ao);  // render/occlusion.py lid_shade
}

float softbox(vec3 r, vec3 l, float soft) {
    float d = dot(r, l);
    vec3 x = normalize(cross(vec3(0.0, 1.0, 0.0), l));
    vec2 q = (vec2(dot(r, x), dot(r, cross(l, x))) / max(d, 1e-3) + vec2(0.0, BOX_DROP)) / BOX;
    q *= q;
    float e = sqrt(sqrt(dot(q, q)));  // a rounded rectangle: |q|_4
    return d > 0.0 ? 1.0 - smoothstep(1.0 - soft, 1.0 + soft, e) : 0.0;
}

vec3 wet_reflection(vec3 n, vec3 v) {
    vec3 r = reflect(-v, n);
    float soft = clamp(24.0 / u_shininess, 0.05, 0.9);
    float x = 1.0 - max(dot(n, v), 0.0);
    float x2 = x * x;
    float fres = u_specular * (0.025 + 0.975 * x2 * x2 * x);
    vec3 studio = CATCH * (u_key_col * softbox(r, u_key_dir, soft)
                           + FILL_CATCH * u_fill_col * softbox(r, u_fill_dir, soft))
                + mix(u_ground, u_sky, 0.5 + 0.5 * r.y);
    return fres * studio;
}

#ifdef IRIS
vec3 eye_u, eye_v;  // the eye's x and y (the eyeball's UV directions) in view space
vec2 iris_q;        // the iris point seen, from the eye's axis in UV units

// The texture coordinates of the iris point seen through the cornea at uv (position p).
vec2 iris_uv(vec2 uv, vec3 p, vec3 v) {
    vec3 dp1 = dFdx(p), dp2 = dFdy(p);
    vec2 d1 = dFdx(uv), d2 = dFdy(uv);
    float det = d1.x * d2.y - d1.y * d2.x;
    eye_u = normalize((dp1 * d2.y - dp2 * d1.y) * det);
    eye_v = normalize((dp2 * d1.x - dp1 * d2.x) * det);
    vec3 axis = cross(eye_u, eye_v);
    vec2 t = vec2(dot(v, eye_u), dot(v, eye_v));
    float c = max(dot(v, axis), 0.25);
    vec2 tr = t / IOR;
    vec2 q = uv - 0.5 + CHAMBER * (t / c - tr / sqrt(1.0 - dot(tr, tr)));
    float len = length(q);
    iris_q = len > IRIS_R ? q * (IRIS_R / len) : q;
    return 0.5 + iris_q;
}

// The key light on the iris: brighter on the side away from the light, darker toward it.
float iris_key() {
    vec2 l = vec2(dot(u_key_dir, eye_u), dot(u_key_dir, eye_v));
    float x = length(iris_q) / IRIS_R;
    float side = dot(iris_q, l) / max(length(iris_q), 1e-4);
    return 1.0 + 1.4 * max(-side, 0.0) * smoothstep(0.35, 0.95, x)
               - 0.45 * max(side, 0.0) * smoothstep(0.6, 1.0, x);
}
#endif
