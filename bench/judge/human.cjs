// Cross-check judge for mimika's expressions, from another model family than judge.cjs:
// @vladmandic/human's face pipeline (BlazeFace detector, FaceMesh) and its emotion model
// (Arriaga's mini-Xception trained on FER2013 photographs: 64×64 grey, 7 classes), on
// TensorFlow.js' WebAssembly backend.
//
//   node human.cjs a.png b.png …      one JSON line per image, in order
//
// Each line: {"file", "box" [x, y, w, h], "expressions" {class: p}} (face-api's class names)
// or {"file", "error"} when no face is found.
"use strict";
const fs = require("fs");
const path = require("path");
const H = require(path.join(__dirname, "node_modules", "@vladmandic", "human", "dist", "human.node-wasm.js"));
const { PNG } = require("pngjs");

// the library fetches its models by URL: serve file:// URLs from disk (Node's fetch does not)
const netFetch = globalThis.fetch;
globalThis.fetch = async (url, init) => {
  const u = String(url);
  if (!u.startsWith("file://")) return netFetch(url, init);
  return new Response(fs.readFileSync(new URL(u)), { status: 200 });
};

//: FER2013 labels → face-api's names (so both judges speak the same classes)
const NAMES = { angry: "angry", disgust: "disgusted", fear: "fearful", happy: "happy",
  sad: "sad", surprise: "surprised", neutral: "neutral" };

async function main() {
  const human = new H.Human({
    backend: "wasm",
    modelBasePath: "file://" + path.join(__dirname, "node_modules", "@vladmandic", "human", "models") + "/",
    wasmPath: "file://" + path.join(__dirname, "node_modules", "@tensorflow", "tfjs-backend-wasm", "dist") + "/",
    debug: false, cacheSensitivity: 0, filter: { enabled: false },
    face: { enabled: true, detector: { rotation: false, maxDetected: 1 }, mesh: { enabled: true },
      iris: { enabled: false }, description: { enabled: false }, antispoof: { enabled: false },
      liveness: { enabled: false }, emotion: { enabled: true, minConfidence: 0 } },
    body: { enabled: false }, hand: { enabled: false }, object: { enabled: false },
    gesture: { enabled: false }, segmentation: { enabled: false },
  });
  await human.load();
  for (const file of process.argv.slice(2)) {
    const png = PNG.sync.read(fs.readFileSync(file));
    const n = png.width * png.height;
    const rgb = new Uint8Array(n * 3);
    for (let i = 0; i < n; i++) for (let c = 0; c < 3; c++) rgb[3 * i + c] = png.data[4 * i + c];
    const t = human.tf.tensor3d(rgb, [png.height, png.width, 3], "int32");
    const t4 = human.tf.expandDims(t, 0);
    const r = await human.detect(t4);
    human.tf.dispose([t, t4]);
    const face = r.face && r.face[0];
    if (!face || !face.emotion) {
      process.stdout.write(JSON.stringify({ file, error: "no face found" }) + "\n");
      continue;
    }
    const expressions = {};
    for (const k of Object.values(NAMES)) expressions[k] = 0;
    for (const e of face.emotion) expressions[NAMES[e.emotion]] = e.score;
    process.stdout.write(JSON.stringify({ file, box: face.box, expressions }) + "\n");
  }
}

main().catch((e) => {
  process.stderr.write(`human judge: ${e.stack || e}\n`);
  process.exit(1);
});
