// Load a .glb with three.js's GLTFLoader in node and print what a player would see:
// meshes, morph target count, morph target names, animation duration and track count.
// usage: node tools/three_load.mjs FILE.glb
import { readFileSync } from "node:fs";
// node has no DOM: let GLTFLoader decode embedded images into placeholders (textures are
// counted, not drawn)
globalThis.self = globalThis;
globalThis.createImageBitmap = async () => ({ width: 1, height: 1, close() {} });
globalThis.Blob = globalThis.Blob ?? class {};
// EXT_texture_webp asks an Image whether WebP decodes: say it does (1×1 after loading)
globalThis.Image = globalThis.Image ?? class {
  set src(_v) { this.height = 1; setTimeout(() => this.onload && this.onload()); }
};
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";

const buf = readFileSync(process.argv[2]);
const ab = buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength);
const loader = new GLTFLoader();
loader.parse(ab, "", (gltf) => {
  let morphTargets = 0, meshes = 0, skinned = 0, textured = 0, bones = 0;
  const names = new Set();
  gltf.scene.traverse((o) => {
    if (o.isMesh) {
      meshes += 1;
      if (o.isSkinnedMesh) { skinned += 1; bones = Math.max(bones, o.skeleton.bones.length); }
      const mats = Array.isArray(o.material) ? o.material : [o.material];
      if (mats.some((m) => m && m.map)) textured += 1;
      const dict = o.morphTargetDictionary || {};
      for (const k of Object.keys(dict)) names.add(k);
      morphTargets = Math.max(morphTargets, o.morphTargetInfluences ? o.morphTargetInfluences.length : 0);
    }
  });
  const anim = gltf.animations[0];
  console.log(JSON.stringify({
    meshes, skinned, textured, bones, morphTargets, morphTargetNames: [...names].sort(),
    animations: gltf.animations.length,
    duration: anim ? anim.duration : 0,
    tracks: anim ? anim.tracks.length : 0,
  }));
}, (err) => { console.error(String(err && err.message || err)); process.exit(1); });
