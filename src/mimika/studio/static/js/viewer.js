// The three.js view: a head from mimika's glTF export (a morph target per AU, a head joint and
// two eye nodes, any textures the GLB carries), drawn in mimika's look (look.js), framed like
// the renderer's cameras (render/camera.py: front, three-quarter, profile).
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { Look } from "./look.js";

const DEG = Math.PI / 180;

// The weight of a character's lip release (the GLB's extras.rig.release): smoothstep of the
// largest of its AUs (per side: the AU plus its one-sided code, at most 1) over full_at.
function releaseWeight(rel, frame) {
  let v = 0;
  for (const c of rel.by) {
    const both = frame[c] || 0;
    v = Math.max(v, Math.min(both + (frame[c + "L"] || 0), 1), Math.min(both + (frame[c + "R"] || 0), 1));
  }
  const t = Math.min(Math.max(v / rel.full_at, 0), 1);
  return t * t * (3 - 2 * t);
}

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(20, 1, 0.01, 20);
    this.camera.position.set(0, 0, 1.2);
    this.meshes = [];
    this.motion = { head_rot: {}, head_tr: {}, eye_rot: {} };
    this.scale = 0.01;
    this.view = "front";
    this.ready = false;
    try {
      this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: false, preserveDrawingBuffer: true });
      this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 1.5));
      this.renderer.outputColorSpace = THREE.SRGBColorSpace;
      this.renderer.toneMapping = THREE.NoToneMapping;  // the look applies the renderer's curve
      this.controls = new OrbitControls(this.camera, canvas);
      this.controls.enableDamping = true;
      this.controls.minDistance = 0.2;
      this.controls.maxDistance = 3;
      this.controls.addEventListener("change", () => { this.dirty = true; });
    } catch (e) {
      this.renderer = null;  // the scene (and its morph weights) still works without a canvas
      this.error = `The 3D view is off: this browser cannot use WebGL (${e.message}).`;
    }
    canvas.addEventListener("keydown", (e) => this.onKey(e));
    this._resize = () => this.resize();
    new ResizeObserver(this._resize).observe(canvas.parentElement);
    this.resize();
  }

  setLookInfo(info) {
    this.lookInfo = info;
    this.look = new Look(info);
    this.camera.fov = info.fov;
  }

  setLook(name) {
    this.look.set(name);
    this.setView(this.view);
    this.dirty = true;
  }

  resize() {
    const r = this.canvas.parentElement.getBoundingClientRect();
    const w = Math.max(1, r.width), h = Math.max(1, r.height);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (this.renderer) this.renderer.setSize(w, h, false);
    this.dirty = true;
  }

  // Load a head's GLB (replacing the one shown); info is /api/head's answer.
  async load(url, info) {
    const gltf = await new GLTFLoader().loadAsync(url);
    this.unload();
    this.motion = info.motion;
    this.scale = info.scale;
    this.frameInfo = info.frame;
    this.root = gltf.scene;
    this.headJoint = this.eyeL = this.eyeR = null;
    // a character's GLB says how AU values move its skeleton (io/gltf_skinned.py)
    this.rig = (gltf.parser.json.extras || {}).rig || null;
    this.look.useWrinkles((gltf.parser.json.extras || {}).wrinkles);
    this.joints = {};
    this.meshes = [];
    const seen = new Set();
    this.root.traverse((o) => {
      if (o.isMesh) {
        o.frustumCulled = false;
        for (const m of Array.isArray(o.material) ? o.material : [o.material]) {
          if (!seen.has(m)) { seen.add(m); this.look.adopt(m, !!o.geometry.attributes._face); }
        }
        if (o.morphTargetDictionary) this.meshes.push(o);
      }
      if (o.isBone || (this.rig && o.type === "Bone")) this.joints[o.name] = o;
      if (o.name === "head" && !this.headJoint) this.headJoint = o;
      if (o.name === "eye_L") this.eyeL = o;
      if (o.name === "eye_R") this.eyeR = o;
    });
    this.scene.add(this.root);
    if (this.headJoint) this.headRest = this.headJoint.position.clone();
    this.ready = true;
    this.setView(this.view);
    this.apply(this.frame || {});
  }

  unload() {
    if (!this.root) return;
    this.scene.remove(this.root);
    this.root.traverse((o) => {
      if (!o.isMesh) return;
      o.geometry.dispose();
      for (const m of Array.isArray(o.material) ? o.material : [o.material]) {
        for (const v of Object.values(m)) if (v && v.isTexture) v.dispose();
        m.dispose();
      }
    });
    this.root = null;
  }

  // A named camera (front | three-quarter | profile), framed as render/camera.py frames it.
  setView(view) {
    this.view = view;
    const f = this.frameInfo;
    if (!f) return;
    const angle = (this.lookInfo.views[view] ?? 0) * DEG;
    // heads with a body: the news look's head-and-shoulders shot (as the newsreader frames it)
    const bust = f.body && this.look.bust_fill;
    const fill = bust ? this.look.bust_fill : this.look.fill;
    const visible = Math.max(f.height / fill, f.width / (0.85 * this.camera.aspect));
    const dist = visible / 2 / Math.tan((this.camera.fov * DEG) / 2);
    const c = new THREE.Vector3(...f.centre);
    if (bust) c.y = f.eye_y - (0.5 - this.look.eye_line) * visible;
    this.camera.position.set(c.x + dist * Math.sin(angle), c.y, c.z + dist * Math.cos(angle));
    this.camera.up.set(0, 1, 0);
    this.camera.lookAt(c);
    if (this.controls) { this.controls.target.copy(c); this.controls.update(); }
    this.dirty = true;
  }

  orbit(dAz, dEl) {
    const t = this.controls ? this.controls.target : new THREE.Vector3();
    const off = this.camera.position.clone().sub(t);
    const s = new THREE.Spherical().setFromVector3(off);
    s.theta += dAz;
    s.phi = Math.min(Math.max(s.phi - dEl, 0.15), Math.PI - 0.15);
    off.setFromSpherical(s);
    this.camera.position.copy(t).add(off);
    this.camera.lookAt(t);
    if (this.controls) this.controls.update();
    this.dirty = true;
  }

  zoom(f) {
    const t = this.controls ? this.controls.target : new THREE.Vector3();
    const off = this.camera.position.clone().sub(t);
    const d = Math.min(Math.max(off.length() * f, 0.2), 3);
    this.camera.position.copy(t).add(off.setLength(d));
    if (this.controls) this.controls.update();
    this.dirty = true;
  }

  onKey(e) {
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    const step = (e.shiftKey ? 15 : 5) * DEG;
    const keys = {
      ArrowLeft: () => this.orbit(-step, 0), ArrowRight: () => this.orbit(step, 0),
      ArrowUp: () => this.orbit(0, step), ArrowDown: () => this.orbit(0, -step),
      "+": () => this.zoom(0.9), "=": () => this.zoom(0.9), "-": () => this.zoom(1.1),
      1: () => this.onViewKey("front"), 2: () => this.onViewKey("three-quarter"),
      3: () => this.onViewKey("profile"), 0: () => this.onViewKey(this.view),
    };
    const f = keys[e.key];
    if (!f) return;
    e.preventDefault();
    f();
  }

  onViewKey(view) { (this.onViewChange || ((v) => this.setView(v)))(view); }

  // Set every morph weight and joint from {AU code: value}; unknown codes are ignored.
  apply(frame) {
    this.frame = frame;
    this.dirty = true;
    this.look.setWrinkles(frame);
    for (const m of this.meshes) {
      const inf = m.morphTargetInfluences, dict = m.morphTargetDictionary;
      inf.fill(0);
      for (const [code, v] of Object.entries(frame)) {
        const i = dict[code];
        if (i !== undefined) inf[i] = v;
      }
      const rel = this.rig && this.rig.release, k = rel ? dict[rel.target] : undefined;
      if (k !== undefined) inf[k] = releaseWeight(rel, frame);
    }
    const rot = (table) => {
      const rv = new THREE.Vector3();
      for (const [code, axis] of Object.entries(table)) {
        const v = frame[code] || 0;
        if (v) rv.add(new THREE.Vector3(...axis).multiplyScalar(v));
      }
      const a = rv.length();
      return a > 1e-9 ? new THREE.Quaternion().setFromAxisAngle(rv.divideScalar(a), a) : new THREE.Quaternion();
    };
    if (this.rig) {
      this.applyRig(frame);
    } else if (this.headJoint) {
      this.headJoint.quaternion.copy(rot(this.motion.head_rot));
      const t = this.headRest.clone();
      for (const [code, vec] of Object.entries(this.motion.head_tr)) {
        const v = frame[code] || 0;
        if (v) t.add(new THREE.Vector3(...vec).multiplyScalar(v * this.scale));
      }
      this.headJoint.position.copy(t);
    }
    const eq = rot(this.motion.eye_rot);
    if (this.eyeL) this.eyeL.quaternion.copy(eq);
    if (this.eyeR) this.eyeR.quaternion.copy(eq);
  }

  // A character: each joint turns by its rest pose + its share of the head AUs + the body
  // channels (rotation vectors about world axes at bind, as the GLB's extras.rig says)
  applyRig(frame) {
    const r = this.rig;
    const head = new THREE.Vector3();
    for (const [code, axis] of Object.entries(r.head_rot)) {
      const v = frame[code] || 0;
      if (v) head.add(new THREE.Vector3(...axis).multiplyScalar(v));
    }
    for (const [name, joint] of Object.entries(this.joints)) {
      const rv = new THREE.Vector3(...(r.rest[name] || [0, 0, 0]));
      rv.addScaledVector(head, r.head_share[name] || 0);
      for (const [chan, bones] of Object.entries(r.body)) {
        const v = frame[chan] || 0;
        if (v && bones[name]) rv.add(new THREE.Vector3(...bones[name]).multiplyScalar(v));
      }
      const a = rv.length();
      joint.quaternion.copy(a > 1e-9 ? new THREE.Quaternion().setFromAxisAngle(rv.divideScalar(a), a)
                                     : new THREE.Quaternion());
      if (name === r.translate_joint) {
        if (!joint.userData.rest) joint.userData.rest = joint.position.clone();
        const t = joint.userData.rest.clone();
        for (const [code, vec] of Object.entries(r.head_translate_m)) {
          const v = frame[code] || 0;
          if (v) t.add(new THREE.Vector3(...vec).multiplyScalar(v));
        }
        joint.position.copy(t);
      }
    }
  }

  // {target name: largest influence over all meshes} — what the tests read
  weights() {
    const out = {};
    for (const m of this.meshes) {
      for (const [name, i] of Object.entries(m.morphTargetDictionary)) out[name] = Math.max(out[name] || 0, m.morphTargetInfluences[i]);
    }
    return out;
  }

  // A PNG data URL of the view framed like the renderer's w×h pictures (the camera the
  // screen shows is kept); used to compare the look with mimika's renderer.
  still(w, h) {
    if (!this.renderer) return null;
    const pos = this.camera.position.clone(), tgt = this.controls.target.clone(), aspect = this.camera.aspect;
    const ratio = this.renderer.getPixelRatio();
    this.renderer.setPixelRatio(1);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.setView(this.view);
    this.look.render(this.renderer, this.scene, this.camera);
    const url = this.canvas.toDataURL("image/png");
    this.renderer.setPixelRatio(ratio);
    this.camera.aspect = aspect;
    this.camera.position.copy(pos);
    this.controls.target.copy(tgt);
    this.camera.lookAt(tgt);
    this.resize();
    this.render();
    return url;
  }

  // Draw only when something changed (software GL on a busy machine needs its CPU back).
  render() {
    if (!this.renderer || !this.look) return;
    if (this.controls) this.controls.update();  // may fire "change" while damping
    if (!this.dirty) return;
    this.dirty = false;
    this.look.render(this.renderer, this.scene, this.camera);
  }
}
