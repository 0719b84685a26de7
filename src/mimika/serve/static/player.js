// mimika player: a three.js head driven by `mimika serve` (ES module, no build step).
// The page maps "three" and "three/addons/" (an import map: the server's own copy is at
// /vendor/three/three.module.js and /vendor/three/addons/, or use yours).
//
//   import { MimikaHead } from "http://127.0.0.1:8787/player.js";
//   const head = new MimikaHead(document.querySelector("#face"), { server: "ws://127.0.0.1:8787/ws" });
//   await head.ready;                 // avatar loaded, connected
//   await head.speak("Good evening."); // resolves when the speech has been played
//   head.setMood("happy"); head.emote("surprise", 0.8, 1.5); head.look(0.3, 0); head.interrupt();
//   const live = await head.stream(audioNode); … live.stop();  // lip-sync for your own audio
//
// The avatar is any glTF/GLB/VRM three.js loads (`avatar: URL`, default the server's
// /head.glb): morph targets named like AUs (mimika's exports: AU12, AU12L …) or ARKit
// (jawOpen, mouthSmileLeft … : Ready Player Me, TalkingHead's avatars) are driven from the
// frames, VRoid's vowel and blink morphs (Fcl_MTH_A …, Fcl_EYE_Close) from the visemes; a bone named like Head/head/neck turns with HeadYaw/HeadPitch/HeadRoll, eye bones
// (LeftEye/RightEye, eye_L/eye_R …) with the eye rotations. Audio plays through Web Audio; its
// clock is the master: a frame with t is shown when the speech has played t seconds.

import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

const HEAD_BONES = /^(head|Head|mixamorigHead|J_Bip_C_Head)$/;
const EYE_BONES = { left: /^(LeftEye|eye_L|Eye_L|J_Adj_L_FaceEye|mixamorigLeftEye)$/,
                    right: /^(RightEye|eye_R|Eye_R|J_Adj_R_FaceEye|mixamorigRightEye)$/ };
const FADE_S = 0.12; // interrupt: back to idle within this
const CHUNK_S = 0.05; // stream(): seconds of audio per listen message
// stream(): an AudioWorklet that hands the node's samples (first channel) to the page
const TAP = `registerProcessor("mimika-tap", class extends AudioWorkletProcessor {
  process(inputs) { const ch = inputs[0][0]; if (ch) this.port.postMessage(ch.slice(0)); return true; }
});`;
// VRoid/VRM faces name their morphs after vowels and blinks: drive them from the viseme
const VRM_VOWEL = { aa: "Fcl_MTH_A", E: "Fcl_MTH_E", ih: "Fcl_MTH_I", oh: "Fcl_MTH_O",
                    ou: "Fcl_MTH_U", CH: "Fcl_MTH_I", SS: "Fcl_MTH_I", RR: "Fcl_MTH_O" };

// A mimika character's lip release (the GLB's extras.rig.release, as its studio viewer
// computes it): smoothstep of the largest of its AUs (per side, at most 1) over full_at.
function releaseWeight(rel, w) {
  let v = 0;
  for (const c of rel.by) {
    const both = w[c] || 0;
    v = Math.max(v, Math.min(both + (w[c + "L"] || 0), 1), Math.min(both + (w[c + "R"] || 0), 1));
  }
  const t = Math.min(Math.max(v / rel.full_at, 0), 1);
  return t * t * (3 - 2 * t);
}

export class MimikaHead {
  constructor(container, { server, avatar = "head.glb", background = 0x20242c } = {}) {
    this.container = container;
    const base = new URL(".", import.meta.url);
    this.server = server || `${base.protocol === "https:" ? "wss" : "ws"}://${base.host}/ws`;
    this.avatarUrl = new URL(avatar, base).href;
    this.stats = { frames: 0, maxMouth: 0, messages: 0, errors: [] };
    this.speech = null;      // {id, start, frames: [], end, resolve}
    this.overlays = [];      // relative frames: {t0, fps, frames}
    this.weights = {};       // what is shown now (name -> value)
    this.mood = "neutral";
    this.nextId = 1;
    this.waiting = new Map();
    this.audio = null;
    this.meshes = [];        // filled when the avatar has loaded
    this.rest = new Map();
    this._scene(background);
    this.ready = Promise.all([this._load(), this._connect()]).then(() => this);
  }

  // -- public API ----------------------------------------------------------------------
  speak(text, opts = {}) { return this._speak({ text, ...opts }); }
  speakSSML(ssml, opts = {}) { return this._speak({ ssml, ...opts }); }
  setMood(mood) { this.mood = mood; return this._request({ type: "mood", mood }); }
  emote(expression, intensity = 1, duration = 2) {
    return this._request({ type: "emote", expression, intensity, duration });
  }
  look(x, y, duration = 2) { return this._request({ type: "look", x, y, duration }); }
  interrupt() {
    if (this.speech) this._endSpeech(true);
    this.ws.send(JSON.stringify({ type: "interrupt" }));
  }
  /** The head's AudioContext (its clock is the master): make the nodes for stream() on it. */
  get audioContext() { return this._audio(); }

  /** Lip-sync for audio the page has itself (an AudioNode: a media element, a WebRTC
   *  stream, the agent's TTS): its samples go to the server as `listen` chunks, the face
   *  follows the frames that come back, and the node is heard through a `delay` (s) so
   *  that sound and face stay in sync (frames arrive ~0.13 s after their instant).
   *  Resolves, once capture runs, to {stop(), done}: stop() ends the stream, done resolves
   *  when its last frame has been shown. */
  async stream(node, { delay = 0.2 } = {}) {
    if (this.speech) this._endSpeech(true);
    const ctx = node.context;
    this.audio = ctx; // the node's clock is the master
    if (!ctx.mimikaTap) {
      ctx.mimikaTap = ctx.audioWorklet.addModule(
        URL.createObjectURL(new Blob([TAP], { type: "text/javascript" })));
    }
    await ctx.mimikaTap;
    const tap = new AudioWorkletNode(ctx, "mimika-tap");
    const mute = ctx.createGain();
    mute.gain.value = 0;
    node.connect(tap).connect(mute).connect(ctx.destination); // pulled, not heard
    const late = ctx.createDelay(Math.max(1, delay));
    late.delayTime.value = delay;
    node.connect(late).connect(ctx.destination);
    const id = `stream-${this.nextId++}`, sr = ctx.sampleRate, chunk = Math.round(sr * CHUNK_S);
    let parts = [], n = 0, open = true;
    const sp = { id, start: null, frames: [], end: null, sources: [] };
    const done = new Promise((resolve, reject) => { sp.resolve = resolve; sp.reject = reject; });
    const send = (final) => {
      const pcm = new Int16Array(n);
      let k = 0;
      for (const p of parts) for (let i = 0; i < p.length; i++) {
        pcm[k++] = Math.max(-32768, Math.min(32767, Math.round(p[i] * 32768)));
      }
      const bytes = new Uint8Array(pcm.buffer);
      let bin = "";
      for (let i = 0; i < bytes.length; i += 0x8000) bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
      this.ws.send(JSON.stringify({ type: "listen", id, sr, final, data: btoa(bin) }));
      parts = []; n = 0;
    };
    tap.port.onmessage = (e) => {
      if (!open) return;
      // the stream's clock: its sample 0 is heard `delay` s after it was captured
      if (sp.start === null) sp.start = ctx.currentTime - e.data.length / sr + delay;
      parts.push(e.data); n += e.data.length;
      if (n >= chunk) send(false);
    };
    this.speech = sp;
    if (ctx.state === "suspended") ctx.resume();
    const stop = () => {
      if (!open) return;
      open = false;
      send(true);
      tap.port.onmessage = null;
      node.disconnect(tap);
      tap.disconnect();
      setTimeout(() => { try { node.disconnect(late); } catch (e) { /* gone */ } }, delay * 1000 + 500);
    };
    return { stop, done };
  }

  // -- connection ----------------------------------------------------------------------
  _connect() {
    return new Promise((resolve, reject) => {
      this.ws = new WebSocket(this.server);
      this.ws.onmessage = (ev) => this._message(JSON.parse(ev.data), resolve);
      this.ws.onerror = () => reject(new Error(`cannot reach mimika serve at ${this.server}`));
      this.ws.onclose = () => { this.connected = false; };
    });
  }

  _request(msg) {
    const id = this.nextId++;
    this.ws.send(JSON.stringify({ ...msg, id }));
    return new Promise((resolve, reject) => this.waiting.set(id, { resolve, reject }));
  }

  _speak(msg) {
    if (this.speech) this._endSpeech(true);
    const ctx = this._audio();
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.speech = { id, start: null, frames: [], end: null, resolve, reject, sources: [] };
      this.ws.send(JSON.stringify({ type: "speak", id, ...msg }));
      if (ctx.state === "suspended") ctx.resume();
    });
  }

  _message(m, onReady) {
    this.stats.messages++;
    if (m.type === "ready") { this.connected = true; this.info = m; onReady(); return; }
    const sp = this.speech;
    if (m.type === "error") {
      this.stats.errors.push(m.message);
      const w = this.waiting.get(m.id);
      if (w) { this.waiting.delete(m.id); w.reject(new Error(m.message)); }
      else if (sp && (m.id === sp.id || m.id === undefined)) {
        const s = this.speech; this._endSpeech(true); s.reject(new Error(m.message));
      }
      return;
    }
    if (m.type === "frames" && m.relative) {
      this.overlays.push({ t0: performance.now() / 1000, fps: m.fps, frames: m.frames });
    } else if (m.type === "frames" && sp && m.id === sp.id) {
      for (const f of m.frames) sp.frames.push(f);
    } else if (m.type === "audio" && sp && m.id === sp.id) {
      this._play(sp, m);
    } else if (m.type === "end" && sp && m.id === sp.id && !m.interrupted) {
      sp.end = m.duration;
    }
    const w = this.waiting.get(m.id);
    if (w && (m.type === "frames" || m.type === "mood")) { this.waiting.delete(m.id); w.resolve(m); }
  }

  _audio() {
    if (!this.audio) this.audio = new (window.AudioContext || window.webkitAudioContext)();
    return this.audio;
  }

  _play(sp, m) {
    const ctx = this._audio();
    const bytes = Uint8Array.from(atob(m.data), (c) => c.charCodeAt(0));
    const pcm = new Int16Array(bytes.buffer, 0, m.samples);
    const buf = ctx.createBuffer(1, m.samples, m.sr);
    const ch = buf.getChannelData(0);
    for (let i = 0; i < m.samples; i++) ch[i] = pcm[i] / 32768;
    if (sp.start === null) sp.start = ctx.currentTime + 0.05; // the audio clock of this speech
    const src = ctx.createBufferSource();
    src.buffer = buf;
    src.connect(ctx.destination);
    src.start(Math.max(sp.start + m.t, ctx.currentTime));
    sp.sources.push(src);
  }

  _endSpeech(interrupted) {
    const sp = this.speech;
    if (!sp) return;
    for (const s of sp.sources) { try { s.stop(); } catch (e) { /* already ended */ } }
    this.speech = null;
    this.fadeFrom = { t: performance.now() / 1000, weights: { ...this.weights } };
    if (!interrupted) sp.resolve();
    else sp.resolve({ interrupted: true });
  }

  // -- scene -----------------------------------------------------------------------------
  _scene(background) {
    const w = this.container.clientWidth || 480, h = this.container.clientHeight || 480;
    this.renderer = new THREE.WebGLRenderer({ antialias: true });
    this.renderer.setSize(w, h);
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.outputColorSpace = THREE.SRGBColorSpace;
    this.container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(background);
    this.camera = new THREE.PerspectiveCamera(25, w / h, 0.01, 100);
    this.scene.add(new THREE.HemisphereLight(0xfff4e8, 0x303040, 1.6));
    const key = new THREE.DirectionalLight(0xfff0e0, 2.2);
    key.position.set(0.6, 0.8, 1.2);
    this.scene.add(key);
    this.renderer.setAnimationLoop(() => this._tick());
  }

  async _load() {
    const gltf = await new GLTFLoader().loadAsync(this.avatarUrl);
    this.root = gltf.scene;
    this.scene.add(this.root);
    this.release = ((gltf.parser.json.extras || {}).rig || {}).release || null;
    this.meshes = [];
    this.root.traverse((o) => {
      if (o.morphTargetDictionary) this.meshes.push(o);
      if (o.isBone || o.type === "Bone" || o.isObject3D) {
        if (!this.headBone && HEAD_BONES.test(o.name)) this.headBone = o;
        if (!this.leftEye && EYE_BONES.left.test(o.name)) this.leftEye = o;
        if (!this.rightEye && EYE_BONES.right.test(o.name)) this.rightEye = o;
      }
    });
    this.rest = new Map();
    for (const b of [this.headBone, this.leftEye, this.rightEye]) {
      if (b) this.rest.set(b, b.quaternion.clone());
    }
    this._frame();
  }

  _frame() {
    // frame the face: the top fifth of the model's bounding box, or the head bone
    const box = new THREE.Box3().setFromObject(this.root);
    const size = box.getSize(new THREE.Vector3());
    const center = new THREE.Vector3();
    if (this.headBone) this.headBone.getWorldPosition(center);
    else center.set((box.min.x + box.max.x) / 2, box.max.y - size.y * 0.1, (box.min.z + box.max.z) / 2);
    const faceH = Math.min(size.y, Math.max(size.x, 0.25)) * (size.y > 1 ? 0.18 : 0.6);
    if (this.headBone) center.y += faceH * 0.15;
    const dist = faceH / Math.tan((this.camera.fov * Math.PI) / 360) * 1.3;
    this.camera.position.set(center.x, center.y, center.z + Math.max(dist, 0.3));
    this.camera.lookAt(center);
  }

  // -- animation -------------------------------------------------------------------------
  _tick() {
    const now = performance.now() / 1000;
    const target = {};
    const sp = this.speech;
    if (sp && sp.start !== null && this.audio) {
      const t = this.audio.currentTime - sp.start;
      const f = this._at(sp.frames, t);
      if (f) Object.assign(target, f);
      if (sp.end !== null && t > sp.end + 0.05) this._endSpeech(false);
    } else {
      this._idle(now, target);
    }
    this.overlays = this.overlays.filter((o) => {
      const k = Math.floor((now - o.t0) * o.fps);
      if (k >= o.frames.length) return false;
      for (const [n, v] of Object.entries(o.frames[Math.max(k, 0)])) {
        if (n !== "t" && typeof v === "number") target[n] = (n.startsWith("Head") || n.includes("Eye") && !n.startsWith("eye")) ? (target[n] || 0) + v : Math.max(target[n] || 0, v);
      }
      return true;
    });
    if (this.fadeFrom) { // back to idle after an interrupt or the end of speech
      const a = Math.min((now - this.fadeFrom.t) / FADE_S, 1);
      for (const [n, v] of Object.entries(this.fadeFrom.weights)) {
        target[n] = (target[n] || 0) * a + v * (1 - a);
      }
      if (a >= 1) this.fadeFrom = null;
    }
    this._apply(target);
    this.renderer.render(this.scene, this.camera);
  }

  _at(frames, t) {
    if (!frames.length || t < frames[0].t) return null;
    let lo = 0, hi = frames.length - 1;
    while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (frames[mid].t <= t) lo = mid; else hi = mid - 1; }
    return frames[lo];
  }

  _idle(now, target) {
    // blinks every 2–6 s while silent
    if (!this.nextBlink || now > this.nextBlink + 0.15) this.nextBlink = now + 2 + Math.random() * 4;
    const b = now > this.nextBlink ? Math.sin(Math.min((now - this.nextBlink) / 0.15, 1) * Math.PI) : 0;
    target.AU45 = b; target.eyeBlinkLeft = b; target.eyeBlinkRight = b;
    target.HeadYaw = 0.03 * Math.sin(now * 0.5); target.HeadPitch = 0.02 * Math.sin(now * 0.37);
  }

  _apply(w) {
    this.weights = w;
    const vowel = VRM_VOWEL[w.viseme];
    if (vowel) w = { ...w, [vowel]: Math.min(1, 0.3 + (w.jawOpen || 0) * 1.5) };
    if (w.eyeBlinkLeft || w.AU45) w = { ...w, Fcl_EYE_Close: Math.max(w.eyeBlinkLeft || 0, w.AU45 || 0) };
    let mouth = 0;
    for (const m of this.meshes) {
      const inf = m.morphTargetInfluences, dict = m.morphTargetDictionary;
      for (const k in dict) inf[dict[k]] = 0;
      for (const [n, v] of Object.entries(w)) {
        if (typeof v !== "number") continue;
        const i = dict[n];
        if (i !== undefined) inf[i] = v;
        const iL = dict[n + "L"], iR = dict[n + "R"];
        if (iL !== undefined && dict[n] === undefined) inf[iL] = v;
        if (iR !== undefined && dict[n] === undefined) inf[iR] = v;
      }
      const k = this.release ? dict[this.release.target] : undefined;
      if (k !== undefined) inf[k] = releaseWeight(this.release, w);
      for (const n of ["jawOpen", "AU26", "AU27", "AU25"]) {
        if (dict[n] !== undefined) mouth = Math.max(mouth, inf[dict[n]]);
      }
    }
    this.stats.frames++;
    if (this.speech) this.stats.maxMouth = Math.max(this.stats.maxMouth, mouth);
    const rot = (bone, yaw, pitch, roll) => {
      if (!bone) return;
      const e = new THREE.Euler(pitch || 0, -(yaw || 0), -(roll || 0), "YXZ");
      bone.quaternion.copy(this.rest.get(bone)).multiply(new THREE.Quaternion().setFromEuler(e));
    };
    rot(this.headBone, w.HeadYaw, w.HeadPitch, w.HeadRoll);
    rot(this.leftEye, w.LeftEyeYaw, w.LeftEyePitch, 0);
    rot(this.rightEye, w.RightEyeYaw, w.RightEyePitch, 0);
  }
}
