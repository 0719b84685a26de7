// Development judge for mimika's expressions: face-api (@vladmandic/face-api) finds the face
// (SSD MobileNet v1), its 68 landmarks and its emotion (7 classes, a CNN trained on photographs
// of people), on TensorFlow.js' WebAssembly backend (no native add-on, no GPU).
//
//   node judge.cjs a.png b.png …      one JSON line per image, in order
//
// Each line: {"file", "score" (face detection), "box" [x, y, w, h], "expressions" {class: p},
// "landmarks" [[x, y] × 68] (pixels)} or {"file", "error"} when no face is found.
"use strict";
const fs = require("fs");
const path = require("path");
const tf = require("@tensorflow/tfjs");
require("@tensorflow/tfjs-backend-wasm");
const faceapi = require("@vladmandic/face-api/dist/face-api.node-wasm.js");
const { PNG } = require("pngjs");

const MODELS = path.join(__dirname, "node_modules", "@vladmandic", "face-api", "model");

function rgbTensor(file) {
  const png = PNG.sync.read(fs.readFileSync(file));
  const n = png.width * png.height;
  const rgb = new Uint8Array(n * 3);
  for (let i = 0; i < n; i++) {
    rgb[3 * i] = png.data[4 * i];
    rgb[3 * i + 1] = png.data[4 * i + 1];
    rgb[3 * i + 2] = png.data[4 * i + 2];
  }
  return tf.tensor3d(rgb, [png.height, png.width, 3], "int32");
}

async function main() {
  await tf.setBackend("wasm");
  await tf.ready();
  await faceapi.nets.ssdMobilenetv1.loadFromDisk(MODELS);
  await faceapi.nets.faceLandmark68Net.loadFromDisk(MODELS);
  await faceapi.nets.faceExpressionNet.loadFromDisk(MODELS);
  const options = new faceapi.SsdMobilenetv1Options({ minConfidence: 0.2, maxResults: 1 });
  for (const file of process.argv.slice(2)) {
    const t = rgbTensor(file);
    let r;
    try {
      r = await faceapi.detectSingleFace(t, options).withFaceLandmarks().withFaceExpressions();
    } finally {
      t.dispose();
    }
    if (!r) {
      process.stdout.write(JSON.stringify({ file, error: "no face found" }) + "\n");
      continue;
    }
    const b = r.detection.box;
    process.stdout.write(JSON.stringify({
      file,
      score: r.detection.score,
      box: [b.x, b.y, b.width, b.height],
      expressions: { ...r.expressions },
      landmarks: r.landmarks.positions.map((p) => [p.x, p.y]),
    }) + "\n");
  }
}

main().catch((e) => {
  process.stderr.write(`judge: ${e.stack || e}\n`);
  process.exit(1);
});
