// mimika's look in three.js: the renderer's lights, materials and backdrops (/api/look), so the
// live view matches mimika's pictures ("plain") and the newsreader's video ("news").
//
// Every material the GLB carries stays a MeshStandardMaterial — so base-colour, normal and
// alpha textures, alpha modes, skinning and morph targets keep working — but its lighting is
// replaced by the renderer's: wrap diffuse with a scatter tint and Blinn–Phong specular
// (render/shaders/mesh.frag.glsl), or for skin in the news look the skin shader's diffuse and
// Torrance–Sparrow/Beckmann specular (render/shaders/skin_final.frag.glsl). The skin shader's
// texture-space blur of the light (σ ≈ 0.6 cm) is left out: on mimika's heads it changes the
// face by about 1/255 on average (scripts/studio_look_compare.py). Tone curve as the renderer's.
import * as THREE from "three";

const v3 = (a) => new THREE.Vector3(...a);
const col = (a) => new THREE.Color(...a);  // linear RGB

const PARS = /* glsl */`
uniform vec3 mk_key_dir; uniform vec3 mk_key_col;
uniform vec3 mk_fill_dir; uniform vec3 mk_fill_col;
uniform vec3 mk_rim_dir; uniform vec3 mk_rim_col;
uniform vec3 mk_sky; uniform vec3 mk_ground;
uniform float mk_exposure; uniform float mk_backface;
uniform float mk_specular; uniform float mk_shininess; uniform float mk_wrap; uniform vec3 mk_scatter;
uniform float mk_glass;      // 1: glass, premultiplied (specular stays where alpha is 0)
uniform float mk_skin;       // 1: the skin shader's model (news look, skin materials)
uniform float mk_roughness; uniform float mk_skin_spec;

vec3 mk_wrapped(vec3 n, vec3 l, vec3 c, float wrap) {
  float ndl = dot(n, l);
  float lambert = max(ndl, 0.0);
  float w = max((ndl + wrap) / (1.0 + wrap), 0.0);
  return c * (lambert + max(w - lambert, 0.0) * mk_scatter);
}
vec3 mk_skin_diffuse(vec3 n, float wrap) {
  return mk_wrapped(n, mk_key_dir, mk_key_col, wrap) + mk_wrapped(n, mk_fill_dir, mk_fill_col, wrap)
       + mk_wrapped(n, mk_rim_dir, mk_rim_col, wrap) + mix(mk_ground, mk_sky, 0.5 + 0.5 * n.y);
}
float mk_blinn(vec3 n, vec3 v, vec3 l) {
  float ndl = max(dot(n, l), 0.0);
  vec3 h = normalize(l + v);
  float norm = (mk_shininess + 8.0) / 25.1327;
  float x = 1.0 - max(dot(v, h), 0.0);
  float x2 = x * x;
  return mk_specular * norm * (1.0 + 2.0 * x2 * x2 * x) * pow(max(dot(n, h), 1e-4), mk_shininess) * ndl;
}
vec3 mk_beckmann(vec3 n, vec3 v, vec3 l, vec3 c) {
  float ndl = dot(n, l);
  if (ndl <= 0.0) return vec3(0.0);
  vec3 hu = l + v;
  vec3 h = normalize(hu);
  float ndh = max(dot(n, h), 1e-4);
  float m2 = mk_roughness * mk_roughness;
  float t2 = (1.0 - ndh * ndh) / (ndh * ndh);
  float d = exp(-t2 / m2) / (3.14159 * m2 * ndh * ndh * ndh * ndh);
  float s = 1.0 - max(dot(h, v), 0.0), s2 = s * s;
  float f = 0.028 + 0.972 * s2 * s2 * s;
  return c * (mk_skin_spec * d * f * ndl * 4.0 / max(dot(hu, hu), 1e-4));
}
vec3 mk_shade(vec3 base, vec3 n, vec3 v, float alpha) {
  float facing = gl_FrontFacing ? 1.0 : mk_backface;
  vec3 c;
  if (mk_skin > 0.5) {
    c = base * mk_skin_diffuse(n, mk_wrap) + mk_beckmann(n, v, mk_key_dir, mk_key_col) + mk_beckmann(n, v, mk_fill_dir, mk_fill_col)
      + mk_beckmann(n, v, mk_rim_dir, mk_rim_col);
  } else {
    float a = mk_glass > 0.5 ? alpha : 1.0;
    c = mk_key_col * (base * (mk_wrapped(n, mk_key_dir, vec3(1.0), mk_wrap)) * a + mk_blinn(n, v, mk_key_dir))
      + mk_fill_col * (base * (mk_wrapped(n, mk_fill_dir, vec3(1.0), mk_wrap)) * a + mk_blinn(n, v, mk_fill_dir))
      + mk_rim_col * base * mk_wrapped(n, mk_rim_dir, vec3(1.0), mk_wrap) * a
      + mix(mk_ground, mk_sky, 0.5 + 0.5 * n.y) * base * a;
  }
  return c * facing;
}
vec3 mk_tone(vec3 c) {
  vec3 x = c * mk_exposure;
  vec3 over = max(x - 0.8, 0.0);
  return min(x, vec3(0.8)) + over / (1.0 + over / 0.2);
}
`;

const BACKDROP_VERT = /* glsl */`
varying vec2 v_uv;
void main() { v_uv = uv; gl_Position = vec4(position.xy, 0.0, 1.0); }`;

// render/shaders/background.frag.glsl and studio.frag.glsl (sRGB out, written directly)
const PLAIN_BG = /* glsl */`
varying vec2 v_uv;
uniform vec3 u_top; uniform vec3 u_bottom; uniform vec3 u_glow; uniform float u_aspect;
void main() {
  vec3 c = mix(u_bottom, u_top, smoothstep(0.0, 1.0, v_uv.y));
  vec2 d = (v_uv - vec2(0.5, 0.58)) * vec2(u_aspect, 1.0);
  float r = length(d);
  c += u_glow * exp(-3.5 * r * r);
  c *= 1.0 - 0.35 * smoothstep(0.45, 1.1, length((v_uv - 0.5) * vec2(u_aspect, 1.0)));
  gl_FragColor = vec4(c, 1.0);
}`;
const NEWS_BG = /* glsl */`
varying vec2 v_uv;
uniform vec3 u_top; uniform vec3 u_bottom; uniform vec3 u_glow; uniform float u_aspect;
float panel(vec2 p, vec2 c, vec2 hs, float soft) {
  vec2 d = abs(p - c) - hs;
  float r = length(max(d, 0.0)) + min(max(d.x, d.y), 0.0);
  return 1.0 - smoothstep(-soft, soft, r);
}
void main() {
  vec2 p = vec2((v_uv.x - 0.5) * u_aspect, v_uv.y - 0.5);
  vec3 c = mix(u_bottom, u_top, smoothstep(0.0, 1.0, v_uv.y));
  vec3 cool = vec3(0.10, 0.16, 0.26);
  c += cool * 0.55 * panel(p, vec2(-0.62, 0.08), vec2(0.10, 0.32), 0.10);
  c += cool * 0.55 * panel(p, vec2(0.62, 0.08), vec2(0.10, 0.32), 0.10);
  c += cool * 0.25 * panel(p, vec2(-0.38, 0.22), vec2(0.05, 0.20), 0.08);
  c += cool * 0.25 * panel(p, vec2(0.38, 0.22), vec2(0.05, 0.20), 0.08);
  c += vec3(0.05, 0.07, 0.10) * exp(-pow((v_uv.y - 0.26) / 0.035, 2.0));
  vec2 g = p - vec2(0.0, 0.08);
  c += u_glow * exp(-3.0 * dot(g, g) / 0.25);
  c *= 1.0 - 0.4 * smoothstep(0.4, 1.0, length(p * vec2(0.8, 1.2)));
  gl_FragColor = vec4(c, 1.0);
}`;
const DESK = /* glsl */`
varying vec2 v_uv;
uniform float u_top;
void main() {
  if (v_uv.y > u_top + 0.004) discard;
  float y = clamp(v_uv.y / max(u_top, 1e-3), 0.0, 1.0);
  vec3 c = mix(vec3(0.045, 0.05, 0.065), vec3(0.12, 0.13, 0.16), y);
  c += vec3(0.10, 0.085, 0.07) * exp(-pow((v_uv.x - 0.5) / 0.35, 2.0)) * y;
  c += vec3(0.35, 0.30, 0.24) * exp(-pow((v_uv.y - u_top) / 0.004, 2.0));
  float a = 1.0 - smoothstep(u_top - 0.001, u_top + 0.004, v_uv.y);
  gl_FragColor = vec4(c, a);
}`;

function quad(material) {
  const m = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material);
  m.frustumCulled = false;
  const s = new THREE.Scene();
  s.add(m);
  return s;
}

export class Look {
  constructor(info) {
    this.info = info;
    this.lights = {};
    for (const k of ["mk_key_dir", "mk_key_col", "mk_fill_dir", "mk_fill_col", "mk_rim_dir", "mk_rim_col", "mk_sky", "mk_ground"]) {
      this.lights[k] = { value: k.endsWith("_dir") ? new THREE.Vector3() : new THREE.Color() };
    }
    this.lights.mk_exposure = { value: 1 };
    this.lights.mk_backface = { value: info.backface };
    this.skinMaterials = [];
    this.bgUniforms = { u_top: { value: new THREE.Vector3() }, u_bottom: { value: new THREE.Vector3() },
      u_glow: { value: new THREE.Vector3() }, u_aspect: { value: 1 } };
    const bg = (frag) => new THREE.ShaderMaterial({ vertexShader: BACKDROP_VERT, fragmentShader: frag,
      uniforms: this.bgUniforms, depthTest: false, depthWrite: false });
    this.backdrops = { plain: quad(bg(PLAIN_BG)), news: quad(bg(NEWS_BG)) };
    this.deskUniforms = { u_top: { value: 0 } };
    this.desk = quad(new THREE.ShaderMaterial({ vertexShader: BACKDROP_VERT, fragmentShader: DESK,
      uniforms: this.deskUniforms, depthTest: false, depthWrite: false, transparent: true }));
    this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
    this.set("plain");
  }

  // Switch every material and the backdrop to look ``name`` (plain | news).
  set(name) {
    const L = this.info.looks[name] || this.info.looks.plain;
    this.name = name;
    this.fill = L.fill;
    const u = this.lights;
    for (const k of ["key", "fill", "rim"]) {
      u[`mk_${k}_dir`].value.copy(v3(L[`${k}_dir`]));
      u[`mk_${k}_col`].value.copy(col(L[`${k}_col`]));
    }
    u.mk_sky.value.copy(col(L.sky));
    u.mk_ground.value.copy(col(L.ground));
    u.mk_exposure.value = L.exposure;
    for (const m of this.skinMaterials) m.userData.mk.mk_skin.value = L.skin_shader ? 1 : 0;
    this.bgUniforms.u_top.value.set(...L.bg_top);
    this.bgUniforms.u_bottom.value.set(...L.bg_bottom);
    this.bgUniforms.u_glow.value.set(...L.bg_glow);
    this.backdrop = L.backdrop === "studio" ? this.backdrops.news : this.backdrops.plain;
    this.deskUniforms.u_top.value = L.desk || 0;
    this.hasDesk = (L.desk || 0) > 0;
  }

  // The renderer's parameters for a GLB material: by name from render/data/materials.json,
  // else derived from its PBR values (roughness → shininess); names with "skin" or "lip" are skin.
  params(material) {
    const mats = this.info.materials;
    const name = (material.name || "").toLowerCase();
    let p = mats[material.name] || mats[name];
    const skinLike = this.info.skin.materials.includes(material.name) || /skin|lip/.test(name);
    if (!p && skinLike) p = { ...mats.skin, color: null, alpha: 1 };
    if (!p) {
      const r = Math.max(material.roughness ?? 0.6, 0.05);
      p = { specular: 0.2, shininess: Math.min(Math.max(2 / (r * r) - 2, 4), 200), wrap: 0, scatter: [1, 1, 1],
        alpha: material.opacity ?? 1, cull: !material.side };
    }
    return { ...p, skin: skinLike, known: !!(mats[material.name] || mats[name]) };
  }

  // Give ``material`` (from GLTFLoader) mimika's lighting; keeps its maps, alpha and morphs.
  adopt(material) {
    const p = this.params(material);
    const textured = !!(material.map || material.alphaMap);
    const glass = material.transparent && !textured;
    if (p.known) material.side = p.cull ? THREE.FrontSide : THREE.DoubleSide;
    if (material.transparent && textured) {
      // hair cards and lashes: alpha to coverage (MSAA) keeps depth order right without sorting
      material.alphaToCoverage = true;
      material.transparent = false;
      material.depthWrite = true;
    } else if (glass) {
      material.premultipliedAlpha = true;
      material.depthWrite = false;
    }
    const mk = {
      mk_specular: { value: p.specular }, mk_shininess: { value: p.shininess }, mk_wrap: { value: p.wrap },
      mk_scatter: { value: col(p.scatter) }, mk_glass: { value: glass ? 1 : 0 },
      mk_skin: { value: 0 }, mk_roughness: { value: this.info.skin.roughness },
      mk_skin_spec: { value: p.specular * this.info.skin.specular },
    };
    material.userData.mk = mk;
    if (p.skin) { this.skinMaterials.push(material); mk.mk_skin.value = this.info.looks[this.name].skin_shader ? 1 : 0; }
    material.onBeforeCompile = (shader) => {
      Object.assign(shader.uniforms, this.lights, mk);
      shader.fragmentShader = shader.fragmentShader
        .replace("void main() {", `${PARS}\nvoid main() {`)
        .replace("#include <lights_fragment_begin>", "")
        .replace("#include <lights_fragment_maps>", "")
        .replace("#include <lights_fragment_end>", "")
        .replace("vec3 outgoingLight = totalDiffuse + totalSpecular + totalEmissiveRadiance;",
          "vec3 outgoingLight = mk_shade(diffuseColor.rgb, normal, normalize(vViewPosition), diffuseColor.a) + totalEmissiveRadiance;")
        .replace("#include <tonemapping_fragment>", "gl_FragColor.rgb = mk_tone(gl_FragColor.rgb);")
        .replace("#include <premultiplied_alpha_fragment>", "");
    };
    material.customProgramCacheKey = () => "mimika-look-1";
    material.needsUpdate = true;
    return material;
  }

  // Draw the backdrop, the scene and (news) the desk in front.
  render(renderer, scene, camera) {
    const size = renderer.getSize(new THREE.Vector2());
    this.bgUniforms.u_aspect.value = size.x / Math.max(size.y, 1);
    renderer.autoClear = false;
    renderer.clear();
    renderer.render(this.backdrop, this.camera);
    renderer.render(scene, camera);
    if (this.hasDesk) renderer.render(this.desk, this.camera);
  }
}
