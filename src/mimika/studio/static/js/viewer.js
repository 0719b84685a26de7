// The three.js view: the head from mimika's glTF export (one morph target per AU, a head joint
// and two eye nodes), lit like mimika's renders: warm key, cool fill, rim, studio backdrop.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

// Lights in camera space, as in mimika/render/renderer.py (linear colours).
const KEY = { dir: [-0.55, 0.55, 0.62], col: [1.0, 0.93, 0.85], k: 2.6 };
const FILL = { dir: [0.75, 0.05, 0.55], col: [0.30, 0.34, 0.40], k: 2.2 };
const RIM = { dir: [0.45, 0.55, -0.7], col: [0.55, 0.55, 0.6], k: 1.6 };
const SKY = [0.24, 0.26, 0.30], GROUND = [0.10, 0.085, 0.075];

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(22, 1, 0.01, 20);
    this.camera.position.set(0, 0, 1.2);
    this.scene.add(this.camera);
    this.meshes = [];
    this.motion = { head_rot: {}, head_tr: {}, eye_rot: {} };
    this.scale = 0.01;
    this.ready = false;
    this.webgl = true;
    try {
      this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: true,
                                                preserveDrawingBuffer: true });
      this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 1.5));
      this.renderer.outputColorSpace = THREE.SRGBColorSpace;
      this.renderer.toneMapping = THREE.ACESFilmicToneMapping;
      this.renderer.toneMappingExposure = 1.05;
      this.controls = new OrbitControls(this.camera, canvas);
      this.controls.enableDamping = true;
      this.controls.minDistance = 0.25;
      this.controls.maxDistance = 3;
      this.controls.addEventListener("change", () => { this.dirty = true; });
    } catch (e) {
      this.webgl = false;  // the scene (and its morph weights) still works without a canvas
      this.renderer = null;
      this.error = `WebGL is unavailable (${e.message}); the 3D view is off`;
    }
    const light = (L) => {
      const c = new THREE.DirectionalLight(new THREE.Color(...L.col), L.k);
      c.position.set(...L.dir);
      c.target.position.set(0, 0, 0);
      this.camera.add(c, c.target);
      return c;
    };
    this.key = light(KEY); this.fill = light(FILL); this.rim = light(RIM);
    this.scene.add(new THREE.HemisphereLight(new THREE.Color(...SKY).multiplyScalar(2.2),
                                             new THREE.Color(...GROUND).multiplyScalar(2.2), 1.0));
    this._resize = () => this.resize();
    window.addEventListener("resize", this._resize);
    this.resize();
  }

  resize() {
    const r = this.canvas.parentElement.getBoundingClientRect();
    const w = Math.max(1, r.width), h = Math.max(1, r.height);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (this.renderer) this.renderer.setSize(w, h, false);
    this.dirty = true;
  }

  async load(url, info) {
    this.motion = info.motion;
    this.scale = info.scale;
    const gltf = await new GLTFLoader().loadAsync(url);
    this.root = gltf.scene;
    this.scene.add(this.root);
    this.meshes = [];
    this.root.traverse((o) => {
      if (o.isMesh && o.morphTargetDictionary) this.meshes.push(o);
      if (o.isMesh) o.frustumCulled = false;
      if (o.name === "head" && !this.headJoint) this.headJoint = o;
      if (o.name === "eye_L") this.eyeL = o;
      if (o.name === "eye_R") this.eyeR = o;
    });
    if (this.headJoint) this.headRest = this.headJoint.position.clone();
    // frame the face: the skin's bounding box, camera slightly above, looking at the eyes
    const box = new THREE.Box3().setFromObject(this.root);
    const size = box.getSize(new THREE.Vector3()), c = box.getCenter(new THREE.Vector3());
    const target = new THREE.Vector3(c.x, c.y + size.y * 0.08, c.z);
    const dist = (size.y * 0.62) / Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    this.camera.position.set(target.x + dist * 0.12, target.y + size.y * 0.04, target.z + dist);
    if (this.controls) { this.controls.target.copy(target); this.controls.update(); }
    this.ready = true;
    this.apply({});
  }

  // Set every morph weight and joint from {AU code: value}; unknown codes are ignored.
  apply(frame) {
    this.frame = frame;
    this.dirty = true;
    for (const m of this.meshes) {
      const inf = m.morphTargetInfluences, dict = m.morphTargetDictionary;
      inf.fill(0);
      for (const [code, v] of Object.entries(frame)) {
        const i = dict[code];
        if (i !== undefined) inf[i] = v;
      }
    }
    const rot = (table) => {
      const rv = new THREE.Vector3();
      for (const [code, axis] of Object.entries(table)) {
        const v = frame[code] || 0;
        if (v) rv.add(new THREE.Vector3(...axis).multiplyScalar(v));
      }
      const a = rv.length();
      return a > 1e-9 ? new THREE.Quaternion().setFromAxisAngle(rv.divideScalar(a), a)
                      : new THREE.Quaternion();
    };
    if (this.headJoint) {
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

  // {target name: largest influence over all meshes} — what the tests read
  weights() {
    const out = {};
    for (const m of this.meshes) {
      for (const [name, i] of Object.entries(m.morphTargetDictionary)) {
        out[name] = Math.max(out[name] || 0, m.morphTargetInfluences[i]);
      }
    }
    return out;
  }

  // Draw only when something changed (software GL on a busy machine needs its CPU back).
  render() {
    if (!this.renderer) return;
    if (this.controls) this.controls.update();  // may fire "change" while damping
    if (!this.dirty) return;
    this.dirty = false;
    this.renderer.render(this.scene, this.camera);
  }
}
