// mimika's look in three.js: the renderer's lights, materials and backdrops (/api/look), so the
// live view matches mimika's pictures ("plain") and the newsreader's video ("news"). The skin
// of a head whose GLB carries face units (the _FACE attribute, extras.wrinkles) takes the
// renderer's AU wrinkles (render/shaders/wrinkles.glsl) as the frame's AUs change; the
// inside of the mouth is darkened by the GLB's vertex colours (COLOR_0). Shadows and ambient
// occlusion are the offline renderer's only.
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

// Lights (lights.glsl) and the skin's wrap diffuse (skin_light.glsl) come from the renderer as
// they are; the rest below follows mesh.frag.glsl (Blinn–Phong, glass) and skin_final.frag.glsl
// (Beckmann), which are whole programs there.
const PARS = /* glsl */`
uniform float u_exposure; uniform float u_backface;
uniform float mk_specular; uniform float mk_shininess;
uniform float mk_glass;      // 1: glass, premultiplied (specular stays where alpha is 0)
uniform float mk_skin;       // 1: the skin shader's model (news look, skin materials)
uniform float mk_roughness; uniform float mk_skin_spec;
// the skin's detail (render/shaders/detail.glsl): its normal map is three.js's own; the gloss
// map and the roughness scale come from the GLB's metallic-roughness map (io/gltf.py: R gloss,
// G the roughness scale × (1.3 − 0.5 gloss) / 2)
float mk_gl = 1.0;
float mk_rs = 1.0;

float mk_blinn(vec3 n, vec3 v, vec3 l) {
  float ndl = max(dot(n, l), 0.0);
  vec3 h = normalize(l + v);
  float shin = mk_shininess / (mk_rs * mk_rs);
  float norm = (shin + 8.0) / 25.1327;
  float x = 1.0 - max(dot(v, h), 0.0);
  float x2 = x * x;
  return mk_gl * mk_specular * norm * (1.0 + 2.0 * x2 * x2 * x) * pow(max(dot(n, h), 1e-4), shin) * ndl;
}
vec3 mk_beckmann(vec3 n, vec3 v, vec3 l, vec3 c) {
  float ndl = dot(n, l);
  if (ndl <= 0.0) return vec3(0.0);
  vec3 hu = l + v;
  vec3 h = normalize(hu);
  float ndh = max(dot(n, h), 1e-4);
  float m2 = mk_roughness * mk_roughness * mk_rs * mk_rs;
  float t2 = (1.0 - ndh * ndh) / (ndh * ndh);
  float d = exp(-t2 / m2) / (3.14159 * m2 * ndh * ndh * ndh * ndh);
  float s = 1.0 - max(dot(h, v), 0.0), s2 = s * s;
  float f = 0.028 + 0.972 * s2 * s2 * s;
  return c * (mk_gl * mk_skin_spec * d * f * ndl * 4.0 / max(dot(hu, hu), 1e-4));
}
vec3 mk_shade(vec3 base, vec3 n, vec3 v, float alpha) {
  float facing = gl_FrontFacing ? 1.0 : u_backface;
  vec3 c;
  if (mk_skin > 0.5) {
    c = base * skin_diffuse(n, 1.0, 1.0) + mk_beckmann(n, v, u_key_dir, u_key_col)
      + mk_beckmann(n, v, u_fill_dir, u_fill_col) + mk_beckmann(n, v, u_rim_dir, u_rim_col);
  } else {
    float a = mk_glass > 0.5 ? alpha : 1.0;
    c = u_key_col * (base * wrapped(n, u_key_dir, vec3(1.0)) * a + mk_blinn(n, v, u_key_dir))
      + u_fill_col * (base * wrapped(n, u_fill_dir, vec3(1.0)) * a + mk_blinn(n, v, u_fill_dir))
      + u_rim_col * base * wrapped(n, u_rim_dir, vec3(1.0)) * a
      + mix(u_ground, u_sky, 0.5 + 0.5 * n.y) * base * a;
  }
  return c * facing;
}
vec3 mk_tone(vec3 c) {
  vec3 x = c * u_exposure;
  vec3 over = max(x - 0.8, 0.0);
  return min(x, vec3(0.8)) + over / (1.0 + over / 0.2);
}
`;

// The renderer's whole-screen shaders (#version 330) as WebGL2 programs.
const es = (src) => src.replace(/^#version .*$/m, "precision highp float;\nprecision highp int;");

function quad(material) {
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(9), 3));  // unused
  const m = new THREE.Mesh(g, material);
  m.frustumCulled = false;
  const s = new THREE.Scene();
  s.add(m);
  return s;
}

export class Look {
  constructor(info) {
    this.info = info;
    this.lights = {};
    for (const k of ["u_key_dir", "u_key_col", "u_fill_dir", "u_fill_col", "u_rim_dir", "u_rim_col", "u_sky", "u_ground"]) {
      this.lights[k] = { value: k.endsWith("_dir") ? new THREE.Vector3() : new THREE.Color() };
    }
    this.lights.u_exposure = { value: 1 };
    this.lights.u_backface = { value: info.backface };
    this.skinMaterials = [];
    const sh = info.shaders;
    this.pars = `${sh.lights}\n${sh["skin_light"]}\n${PARS}`;
    this.bgUniforms = { u_top: { value: new THREE.Vector3() }, u_bottom: { value: new THREE.Vector3() },
      u_glow: { value: new THREE.Vector3() }, u_aspect: { value: 1 } };
    const program = (frag, uniforms, extra = {}) => new THREE.RawShaderMaterial({ glslVersion: THREE.GLSL3,
      vertexShader: es(sh["background.vert"]), fragmentShader: es(frag), uniforms, depthTest: false, depthWrite: false, ...extra });
    this.backdrops = { plain: quad(program(sh["background.frag"], this.bgUniforms)),
      news: quad(program(sh["studio.frag"], this.bgUniforms)) };
    this.deskUniforms = { u_top: { value: 0 } };
    this.desk = quad(program(sh["desk.frag"], this.deskUniforms, { transparent: true }));
    this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
    this.useWrinkles(null);
    this.set("plain");
  }

  // Switch every material and the backdrop to look ``name`` (plain | news).
  set(name) {
    const L = this.info.looks[name] || this.info.looks.plain;
    this.name = name;
    this.fill = L.fill;
    const u = this.lights;
    for (const k of ["key", "fill", "rim"]) {
      u[`u_${k}_dir`].value.copy(v3(L[`${k}_dir`]));
      u[`u_${k}_col`].value.copy(col(L[`${k}_col`]));
    }
    u.u_sky.value.copy(col(L.sky));
    u.u_ground.value.copy(col(L.ground));
    u.u_exposure.value = L.exposure;
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

  // The wrinkles of a head (a GLB's extras.wrinkles, render/wrinkles.py): its landmark
  // uniforms and per-frame depths, shared by every wrinkled material; null for none.
  useWrinkles(desc) {
    this.wrinkles = desc || null;
    this.wrUniforms = { u_wr: { value: new Float32Array(28) } };
    if (!desc) return;
    for (const [k, v] of Object.entries(desc.uniforms)) {
      this.wrUniforms[k] = { value: Array.isArray(v) ? new THREE.Vector2(...v) : v };
    }
    this.setWrinkles({});
  }

  // Each wrinkle group's depth per side for AU values {code: value} (as Wrinkles.weights).
  setWrinkles(frame) {
    const d = this.wrinkles;
    if (!d) return;
    const amount = new Float64Array(2 * d.groups.length);
    const sides = {};
    for (const [code, v] of Object.entries(frame)) {
      const base = code.slice(0, 4), side = code.slice(4);
      if (!d.aus[base] || !v) continue;
      const lr = sides[base] || (sides[base] = [0, 0]);
      if (side === "" || side === "L") lr[0] += v;
      if (side === "" || side === "R") lr[1] += v;
    }
    for (const [base, lr] of Object.entries(sides)) {
      for (const [g, k] of Object.entries(d.aus[base])) {
        const i = d.groups.indexOf(g);
        amount[2 * i] += k * Math.min(lr[0], 1);
        amount[2 * i + 1] += k * Math.min(lr[1], 1);
      }
    }
    const w = this.wrUniforms.u_wr.value;
    for (let j = 0; j < amount.length; j++) {
      w[j] = Math.max(Math.min(amount[j], 1) * d.depth[j >> 1], d.rest[j]);
    }
  }

  // Give ``material`` (from GLTFLoader) mimika's lighting; keeps its maps, alpha and morphs.
  // ``wrinkled``: the material's mesh carries face units (the skin).
  adopt(material, wrinkled = false) {
    const p = this.params(material);
    const wr = wrinkled && p.skin && !!this.wrinkles;
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
      mk_specular: { value: p.specular }, mk_shininess: { value: p.shininess }, u_wrap: { value: p.wrap },
      u_scatter: { value: col(p.scatter) }, mk_glass: { value: glass ? 1 : 0 },
      mk_skin: { value: 0 }, mk_roughness: { value: this.info.skin.roughness },
      mk_skin_spec: { value: p.specular * this.info.skin.specular },
    };
    material.userData.mk = mk;
    if (p.skin) { this.skinMaterials.push(material); mk.mk_skin.value = this.info.looks[this.name].skin_shader ? 1 : 0; }
    material.onBeforeCompile = (shader) => {
      Object.assign(shader.uniforms, this.lights, mk, wr ? this.wrUniforms : {});
      if (wr) {
        shader.vertexShader = shader.vertexShader.replace("void main() {",
          "in vec3 _face;\nout vec3 v_face;\nvoid main() {\n  v_face = _face;");
        shader.fragmentShader = shader.fragmentShader
          .replace("void main() {", `${this.info.shaders.wrinkles}\nvoid main() {`)
          .replace("#include <normal_fragment_maps>", "#include <normal_fragment_maps>\n"
            + "  { float mk_cav; normal = wrinkled_normal(normal, -vViewPosition, mk_cav); diffuseColor.rgb *= mk_cav; }");
      }
      shader.fragmentShader = shader.fragmentShader
        .replace("void main() {", `${this.pars}\nvoid main() {`)
        .replace("#include <roughnessmap_fragment>", "#include <roughnessmap_fragment>\n#ifdef USE_ROUGHNESSMAP\n"
          + "  mk_gl = texelRoughness.r; mk_rs = 2.0 * texelRoughness.g / (1.3 - 0.5 * texelRoughness.r);\n#endif")
        .replace("#include <lights_fragment_begin>", "")
        .replace("#include <lights_fragment_maps>", "")
        .replace("#include <lights_fragment_end>", "")
        .replace("vec3 outgoingLight = totalDiffuse + totalSpecular + totalEmissiveRadiance;",
          "vec3 outgoingLight = mk_shade(diffuseColor.rgb, normal, normalize(vViewPosition), diffuseColor.a) + totalEmissiveRadiance;")
        .replace("#include <tonemapping_fragment>", "gl_FragColor.rgb = mk_tone(gl_FragColor.rgb);")
        .replace("#include <premultiplied_alpha_fragment>", "");
    };
    material.customProgramCacheKey = () => (wr ? "mimika-look-1-wrinkles" : "mimika-look-1");
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
