// Validate a .glb/.gltf with the Khronos glTF-Validator; prints the report summary as JSON.
// usage: node tools/validate.mjs FILE
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
const require = createRequire(import.meta.url);
const validator = require("gltf-validator");

const file = process.argv[2];
const data = new Uint8Array(readFileSync(file));
const report = await validator.validateBytes(data, { maxIssues: 50, format: file.endsWith(".glb") ? "glb" : "gltf" });
const messages = report.issues.messages.map((m) => ({ code: m.code, severity: m.severity, pointer: m.pointer, message: m.message }));
console.log(JSON.stringify({
  validatorVersion: report.validatorVersion,
  numErrors: report.issues.numErrors,
  numWarnings: report.issues.numWarnings,
  numInfos: report.issues.numInfos,
  messages,
  info: report.info ? { morphTargets: report.info.morphTargetCount ?? null, animations: report.info.animationCount, totalVertexCount: report.info.totalVertexCount } : null,
}));
