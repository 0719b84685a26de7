// mimika studio: wires the viewer, designer panels, timeline editor and player together.
import { api, download } from "./api.js";
import { el, toast, debounce, fmt } from "./ui.js";
import { Viewer } from "./viewer.js";
import { AUPanel, ExpressionPanel, LatentPanel, showTrace } from "./panels.js";
import { TimelineEditor } from "./timeline.js";
import { Player } from "./player.js";

const $ = (id) => document.getElementById(id);
const NAME_RE = /^[A-Za-z0-9](?:[A-Za-z0-9 _-]{0,62}[A-Za-z0-9_-])?$/;

const DEFAULT_TEXT = "Good evening. Here is the news from mimika studio.";

function emptyProject(text = DEFAULT_TEXT) {
  return { format: "mimika-project", version: 1,
    settings: { head: "builtin", fps: 25.0, view: "front", lang: $("lang").value, blend: $("opt-blend").checked, size: [640, 480] },
    timeline: { rate: 0.16, mood: null, duration: null, speech: { attrs: [], tokens: text ? [{ text }] : [] }, channels: [] } };
}

const plainText = (p) => p.timeline.speech.tokens.filter((t) => "text" in t).map((t) => t.text).join("");

const S = { project: null, pose: {}, blended: null, source: "designer", status: null, endedAt: null };
let viewer, panel, editor, player, exprs;

function setSource(s) { S.source = s; $("mode-badge").textContent = s; }

function showPose() {
  const blend = $("opt-blend").checked;
  viewer.apply(blend && S.blended ? S.blended : S.pose);
}

const runBlend = debounce(async () => {
  const pose = S.pose;
  const r = await api("/api/blend", { method: "POST", body: { aus: pose } }).catch(() => null);
  if (!r || pose !== S.pose) return;
  S.blended = r.aus;
  showTrace($("trace"), r, pose);
  if (S.source === "designer") showPose();
}, 40);

function onPose(pose) {
  S.pose = pose;
  S.blended = null;
  if (player && player.mode !== "idle") player.stop();
  setSource("designer");
  viewer.apply(pose);        // instant feedback; the blended pose follows
  runBlend();
}

function syncText() {
  const text = $("speech-text").value;
  if (text !== plainText(S.project)) {
    S.project.timeline.speech.tokens = text ? [{ text }] : [];
    for (const c of S.project.timeline.channels) for (const e of c.events) { delete e.anchor; delete e.at; }
  }
  S.project.settings.lang = $("lang").value;
  S.project.settings.blend = $("opt-blend").checked;
}

const resample = debounce(async () => {
  syncText();
  const r = await api("/api/timeline/sample", { method: "POST", body: { project: S.project, fps: 30 } }).catch(() => null);
  if (r) { player.tl = r; if (S.source === "timeline" && player.mode === "idle") viewer.apply(player.frameAt(editor.time)); }
}, 120);

function setProject(p, name) {
  S.project = p;
  $("speech-text").value = plainText(p);
  $("lang").value = p.settings.lang || "en";
  $("opt-blend").checked = !!p.settings.blend;
  if (name !== undefined) $("project-name").value = name;
  player.stop();
  player.key = null; player.segments = []; editor.words = []; editor.speechEnd = 0;
  editor.setProject(p);
  resample();
}

function seek(t) {
  if (player.mode !== "idle") player.stop();
  editor.setTime(t);
  $("clock").textContent = `${fmt(t)} s`;
  setSource("timeline");
  viewer.apply(player.frameAt(t));
  subtitle(t);
}

function subtitle(t) {
  const box = $("subtitle");
  const s = player.sentences.find((x) => t >= x.start && t < x.end + 0.3);
  if (!s || player.mode === "idle" && S.source !== "timeline") { box.style.display = "none"; return; }
  box.style.display = "block";
  box.innerHTML = "";
  if (!s.words.length) { box.textContent = s.text; return; }
  for (const w of s.words) box.append(el("span", { class: `w${t >= w.start && t < w.end ? " now" : ""}` }, w.text), " ");
}

async function speak() {
  syncText();
  const text = $("speech-text").value.trim();
  if (!text) { toast("type something to speak first"); return; }
  setSource("speaking");
  $("latency").textContent = "…";
  await player.speak({ text, lang: $("lang").value, project: S.project, blend: $("opt-blend").checked });
}

async function remix(key) {
  syncText();
  try {
    return await api(`/api/speech/${key}/frames`, { method: "POST", body: { project: S.project, fps: 30, blend: $("opt-blend").checked }, quiet: true });
  } catch (e) {
    if (e.status === 404) { toast("the speech expired on the server; press Speak again", "info"); return null; }
    toast(e.message);
    return null;
  }
}

async function play() {
  setSource("playing");
  // the playhead still where the last playback ended: play again from the start
  await player.play(editor.time === S.endedAt ? 0 : editor.time, remix);
}

function projectName() {
  const name = $("project-name").value.trim();
  if (!name) { toast("give the project a name first"); return null; }
  return name;
}

async function save() {
  const name = projectName();
  if (!name) return;
  syncText();
  const r = await api(`/api/projects/${encodeURIComponent(name)}`, { method: "PUT", body: S.project }).catch(() => null);
  if (!r) return;
  toast(`saved “${r.saved}”`, "ok", 2500);
  await refreshProjects(name);
}

async function load(name) {
  if (!name) { toast("choose a saved project to load"); return; }
  const p = await api(`/api/projects/${encodeURIComponent(name)}`).catch(() => null);
  if (!p) return;
  setProject(p, name);
  toast(`loaded “${name}”`, "ok", 2000);
}

async function refreshProjects(selected) {
  const r = await api("/api/projects").catch(() => ({ projects: [] }));
  const sel = $("project-list");
  sel.innerHTML = "";
  sel.append(el("option", { value: "" }, "— saved projects —"));
  for (const p of r.projects) sel.append(el("option", { value: p.name, selected: p.name === selected }, p.name));
}

function exportName() {
  const n = ($("project-name").value.trim() || "mimika").replace(/[^A-Za-z0-9_-]+/g, "-").replace(/^-+|-+$/g, "");
  return n || "mimika";
}

async function exportAs(kind) {
  syncText();
  const name = exportName();
  const usePose = S.source === "designer" && !S.project.timeline.channels.some((c) => c.events.length) && !plainText(S.project).trim();
  const body = usePose ? { aus: S.blended || S.pose, name, fps: 30 } : { project: S.project, name, fps: 30 };
  if (kind === "mp4" && !S.status.features.mp4) { toast(`${S.status.features.mp4_reason || "MP4 export isn't available"}; export glTF or CSV instead`); return; }
  if (kind === "csv") body.format = $("csv-format").value;
  const ext = { gltf: "glb", csv: "csv", mp4: "mp4" }[kind];
  toast(`exporting ${name}.${ext}…`, "info", 1500);
  const size = await download(`/api/export/${kind}`, body, `${name}.${ext}`).catch(() => null);
  if (size) toast(`exported ${name}.${ext} (${(size / 1024).toFixed(0)} KiB)`, "ok", 2500);
}

function loop() {
  const t = player.clock();
  if (t !== null && t >= 0) {
    if (player.finished(t)) {
      player.stop();
      S.endedAt = editor.time;
    } else {
      const f = player.frameAt(t);
      viewer.apply(f);
      editor.setTime(t);
      $("clock").textContent = `${fmt(t)} s`;
      subtitle(t);
      const m = player.metrics;
      if (player.mode === "live" && m.firstMotionMs === undefined && player.segments.some((s) => t >= s.t0)) {
        m.firstMotionMs = performance.now() - m.t_speak;
        showLatency(m);
      }
    }
  }
  viewer.render();
  requestAnimationFrame(loop);
}

function showLatency(m) {
  const parts = [];
  if (m.firstAudioMs !== undefined) parts.push(`first sound ${m.firstAudioMs.toFixed(0)} ms`);
  if (m.firstMotionMs !== undefined) parts.push(`motion ${m.firstMotionMs.toFixed(0)} ms`);
  if (m.serverFirstAudioMs !== undefined) parts.push(`server ${m.serverFirstAudioMs.toFixed(0)} ms`);
  $("latency").textContent = parts.join(" · ");
}

async function main() {
  viewer = new Viewer($("view"));
  if (viewer.error) toast(viewer.error, "info");
  const [status, head] = await Promise.all([api("/api/status"), api("/api/head")]);
  S.status = status;
  $("status-line").textContent = `head: ${head.head} · mimika ${status.version}`;
  $("btn-export-mp4").title = status.features.mp4 ? "H.264 video with the speech (rendered on the server)" : status.features.mp4_reason;
  panel = new AUPanel($("au-groups"), head.groups, onPose);
  exprs = new ExpressionPanel({ list: $("expr-list"), filter: $("expr-filter"), nameInput: $("expr-name"), saveBtn: $("btn-expr-save"),
    onApply: (e) => panel.setPose(e.aus), onAdd: (e) => editor.addExpression(e.name), getPose: () => panel.pose() });
  player = new Player({ audio: $("audio"),
    onSentence: (sents) => { editor.words = sents.flatMap((s) => s.words); editor.speechEnd = Math.max(...sents.map((s) => s.end)); editor.render(); },
    onState: (mode) => { $("btn-speak").disabled = false; if (mode === "idle" && S.source !== "designer") setSource("timeline"); },
    onLatency: showLatency });
  player.onError = (msg) => toast(msg);
  editor = new TimelineEditor({ heads: $("tl-heads"), scroll: $("tl-scroll"), canvas: $("tl-canvas"), ruler: $("tl-ruler"),
    lanes: $("tl-lanes"), playhead: $("tl-playhead"), params: $("param-body"), easings: status.easings,
    onChange: () => resample(), onSeek: seek,
    expressionNames: () => exprs.names(), defaultExpression: () => "happiness" });
  setProject(emptyProject());
  window.mimikaStudio.ready = false;
  await Promise.all([viewer.load("/api/head.glb", head), exprs.refresh(), refreshProjects()]);
  new LatentPanel($("latent-panel"), $("latent-sliders"), $("latent-label"), (aus) => panel.setPose(aus)).init();

  $("btn-speak").addEventListener("click", speak);
  $("btn-play").addEventListener("click", play);
  $("btn-stop").addEventListener("click", () => player.stop());
  $("btn-save").addEventListener("click", save);
  $("btn-load").addEventListener("click", () => load($("project-list").value));
  $("btn-new").addEventListener("click", () => setProject(emptyProject(""), ""));
  $("btn-reset").addEventListener("click", () => panel.setPose({}));
  $("btn-export-gltf").addEventListener("click", () => exportAs("gltf"));
  $("btn-export-csv").addEventListener("click", () => exportAs("csv"));
  $("btn-export-mp4").addEventListener("click", () => exportAs("mp4"));
  $("opt-blend").addEventListener("change", () => { S.project.settings.blend = $("opt-blend").checked; showPose(); resample(); });
  $("speech-text").addEventListener("input", () => { player.key = null; resample(); });
  $("lang").addEventListener("change", () => { player.key = null; syncText(); });
  $("zoom-in").addEventListener("click", () => editor.zoom(1.25));
  $("zoom-out").addEventListener("click", () => editor.zoom(0.8));
  document.addEventListener("keydown", (e) => {
    if ((e.ctrlKey || e.metaKey) && e.key === "s") { e.preventDefault(); save(); }
    if (e.key === "Delete" && document.activeElement === document.body) editor.remove();
  });
  requestAnimationFrame(loop);
  window.mimikaStudio.ready = true;
}

window.mimikaStudio = {
  ready: false,
  get viewer() { return viewer; }, get player() { return player; }, get editor() { return editor; },
  get panel() { return panel; }, get project() { return S.project; }, state: S,
  weights: () => viewer.weights(),
  metrics: () => ({ ...player.metrics }),
  audio: () => $("audio"),
  clock: () => player.clock(),
  NAME_RE,
};
main().catch((e) => { console.error(e); toast(`studio failed to start: ${e.message}`); });
