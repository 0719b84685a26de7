// mimika studio: wires the viewer, the panels, the timeline editor, the player, undo/redo and
// the project files together.
import { api, sentence } from "./api.js";
import { el, toast, debounce, fmt } from "./ui.js";
import { Viewer } from "./viewer.js";
import { AUPanel } from "./aupanel.js";
import { LibraryPanel } from "./library.js";
import { BlenderPanel } from "./blender.js";
import { LatentPanel } from "./latent.js";
import { TimelineEditor } from "./timeline.js";
import { Player } from "./player.js";
import { History } from "./history.js";
import { Files, NAME_RE } from "./files.js";
import { setupKeys, setupTabs, setupMenus } from "./keys.js";

const $ = (id) => document.getElementById(id);
const DEFAULT_TEXT = "Good evening. Here is the news from mimika studio.";
const LAYERS = ["blink", "gaze", "head", "brows", "smile"];
const LAYER_LABEL = { blink: "Blinks", gaze: "Gaze", head: "Head motion", brows: "Brow raises", smile: "Smiles at greeting and farewell" };

const S = { project: null, pose: {}, blended: null, trace: null, source: "designer", status: null, endedAt: null,
  saved: null, head: null, heads: [], maxText: 5000 };
let viewer, panel, editor, player, library, blender, latent, history, files;

function emptyProject(text = DEFAULT_TEXT) {
  const cur = S.project ? S.project.settings : {};
  return { format: "mimika-project", version: 1,
    settings: { head: cur.head || S.head || "builtin", fps: 25.0, view: cur.view || "front", lang: $("lang").value,
      blend: $("opt-blend").checked, size: [640, 480], look: cur.look || "plain", behaviour: [...LAYERS], blender_off: [] },
    timeline: { rate: 0.16, mood: null, duration: null, speech: { attrs: [], tokens: text ? [{ text }] : [] }, channels: [] } };
}

const plainText = (p) => p.timeline.speech.tokens.filter((t) => "text" in t).map((t) => t.text).join("");
const text = () => $("speech-text").value;

function setSource(s) { S.source = s; $("mode-badge").textContent = s; }

// -- the designer pose ---------------------------------------------------------------------------
function currentPose() { return S.project.settings.blend && S.blended ? S.blended : S.pose; }

function showPose() { viewer.apply(currentPose()); }

const runBlend = debounce(async () => {
  const pose = S.pose;
  if (!S.project.settings.blend) { S.blended = null; blender.showTrace(null, pose); return; }
  const r = await api("/api/blend", { method: "POST", body: { aus: pose, disabled: blender.disabled() }, quiet: true }).catch(() => null);
  if (!r || pose !== S.pose) return;
  S.blended = r.aus;
  blender.showTrace(r, pose);
  if (S.source === "designer") showPose();
}, 40);

function onPose(pose) {
  S.pose = pose;
  S.blended = null;
  if (player && player.mode !== "idle") player.stop();
  setSource("designer");
  viewer.apply(pose);  // instant feedback; the blended pose follows
  runBlend();
}

// -- the project ---------------------------------------------------------------------------------
function syncText() {
  const t = text();
  if (t !== plainText(S.project)) {
    S.project.timeline.speech.tokens = t ? [{ text: t }] : [];
    for (const c of S.project.timeline.channels) for (const e of c.events) { delete e.anchor; delete e.at; }
  }
  S.project.settings.lang = $("lang").value;
}

function textFits() {
  const n = text().length;
  if (n <= S.maxText) return true;
  toast(`The text is ${n.toLocaleString("en")} characters long; the studio speaks at most ${S.maxText.toLocaleString("en")} at a time. Shorten it by ${(n - S.maxText).toLocaleString("en")} characters, or split it into two projects.`);
  $("speech-text").focus();
  return false;
}

function showCount() {
  const n = text().length, box = $("text-count"), over = n > S.maxText;
  box.classList.toggle("over", over);
  box.textContent = over ? `${n.toLocaleString("en")} / ${S.maxText.toLocaleString("en")} characters — ${(n - S.maxText).toLocaleString("en")} too many to speak; shorten the text`
    : `${n.toLocaleString("en")} / ${S.maxText.toLocaleString("en")} characters`;
  if (over) $("speech-text").setAttribute("aria-invalid", "true"); else $("speech-text").removeAttribute("aria-invalid");
}

function forgetSpeech() {
  player.clearSpeech();
  editor.words = []; editor.speechEnd = 0;
  editor.render();
  $("subtitle").style.display = "none";
  $("latency").textContent = "";
}

// The studio's own settings with their defaults (older projects lack them).
function withDefaults(p) {
  const st = p.settings;
  if (!Array.isArray(st.behaviour)) st.behaviour = [...LAYERS];
  if (!Array.isArray(st.blender_off)) st.blender_off = [];
  if (!st.look) st.look = "plain";
  if (!st.view) st.view = "front";
  return p;
}

// Show project p (a new object) everywhere; keeps the speech when the text is the same.
async function setProject(p, { name } = {}) {
  const before = S.project ? plainText(S.project) + "|" + S.project.settings.lang : null;
  S.project = withDefaults(p);
  const st = S.project.settings;
  $("speech-text").value = plainText(p);
  $("lang").value = st.lang || "en";
  $("opt-blend").checked = !!st.blend;
  $("look-select").value = st.look;
  for (const box of $("layers").querySelectorAll("input")) box.checked = st.behaviour.includes(box.value);
  blender.setDisabled(st.blender_off);
  if (name !== undefined) $("project-name").value = name;
  if (player.mode !== "idle") player.stop();
  editor.setProject(S.project);
  if (before !== plainText(p) + "|" + st.lang) forgetSpeech();
  showCount();
  if (st.head !== S.head) {
    try {
      await useHead(st.head);
    } catch (e) {  // a project made on another computer: keep it on the head shown
      toast(`${e.message} The project stays on the ${S.head} head.`);
      st.head = S.head;
    }
  }
  if (editor.missing().length) expressionsKnown();
  if (st.look !== viewer.look.name) viewer.setLook(st.look);
  if (st.view !== viewer.view) setView(st.view, false);
  runBlend();
  resample();
}

async function loadProject(p, name, message) {
  try {
    await setProject(p, { name });
  } catch (e) {
    toast(e.message || String(e));
    return false;
  }
  history.commit();
  toast(message, "ok", 2500, history.canUndo ? { label: "Undo", run: undo } : null);
  return true;
}

function markSaved(doc) { S.saved = JSON.stringify(doc); updateDirty(); }
function dirty() { syncText(); return S.saved !== null && JSON.stringify(S.project) !== S.saved; }
function updateDirty() {
  const d = S.saved !== null && JSON.stringify(S.project) !== S.saved;
  document.title = `${d ? "• " : ""}${$("project-name").value.trim() || "untitled"} — mimika studio`;
  if (!S.loadingHead) $("status-line").textContent = d ? "unsaved changes" : `mimika ${S.status.version}`;
}

// -- undo / redo ---------------------------------------------------------------------------------
// What undo restores: the project and the sliders (not the selection, the camera or playback).
function snapshot() {
  if (S.project && text() !== plainText(S.project)) syncText();
  return { project: S.project, pose: panel ? panel.state() : { values: {}, split: [] } };
}

function commit() { syncText(); history.commit(); updateDirty(); }

async function restore(state) {
  if (!state) return;
  const sel = editor.selection();
  await setProject(state.project);
  panel.setState(state.pose);
  if (sel) editor.reselect(sel.channel, sel.index);
  updateDirty();
}
async function undo() { await restore(history.undo()); }
async function redo() { await restore(history.redo()); }

// -- heads, views, looks -------------------------------------------------------------------------
async function useHead(name) {
  const sel = $("head-select");
  sel.disabled = true;
  S.loadingHead = true;
  $("status-line").textContent = `loading the ${name} head…`;
  try {
    const q = `?name=${encodeURIComponent(name)}`;
    const info = await api(`/api/head${q}`, { quiet: true });
    await viewer.load(`/api/head.glb${q}`, info);
    const state = panel.state();
    panel.build(info.groups);
    panel.setState(state);  // AUs the new head lacks are dropped
    S.head = name;
    sel.value = name;
  } catch (e) {
    sel.value = S.head;
    throw new Error(`The ${name} head could not be loaded: ${e.message}`);
  } finally {
    sel.disabled = false;
    S.loadingHead = false;
    updateDirty();
  }
}

function setView(view, record = true) {
  viewer.setView(view);
  for (const b of document.querySelectorAll("#view-tools [data-view]")) b.setAttribute("aria-pressed", String(b.dataset.view === view));
  if (record && S.project.settings.view !== view) { S.project.settings.view = view; commit(); }
}

// -- timeline and playback -----------------------------------------------------------------------
// A trigger naming an expression the library lacks: say which, select it; true if none.
function expressionsKnown() {
  const lost = editor.missing();
  if (!lost.length) return true;
  const { channel, index, ev } = lost[0];
  toast(`${editor.trackLabel(channel)} track, trigger ${index + 1} (at ${fmt(ev.start)} s) uses “${ev.name}”, which is not in your library. Choose another expression for it in the Trigger panel, or save one under that name.`);
  editor.select({ channel, ev });
  return false;
}

async function sampleTimeline() {
  syncText();
  if (editor.missing().length) return;  // the server would refuse the timeline: see expressionsKnown()
  const r = await api("/api/timeline/sample", { method: "POST", body: { project: S.project, fps: 30 }, quiet: true }).catch((e) => {
    if (e.status === 422) toast(e.message);
    return null;
  });
  if (r) { player.tl = r; if (S.source === "timeline" && player.mode === "idle") viewer.apply(player.frameAt(editor.time)); }
}
const resample = debounce(() => { S.sampling = sampleTimeline(); }, 120);

// The timeline as edited so far (an edit may still be waiting to be sampled).
async function sampled() {
  resample.flush();
  await S.sampling;
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
  if (!s || (player.mode === "idle" && S.source !== "timeline")) { box.style.display = "none"; return; }
  box.style.display = "block";
  box.innerHTML = "";
  if (!s.words.length) { box.textContent = s.text; return; }
  for (const w of s.words) box.append(el("span", { class: `w${t >= w.start && t < w.end ? " now" : ""}` }, w.text), " ");
}

async function speak() {
  syncText();
  const t = text().trim();
  if (!t) { toast("Type something to speak first."); $("speech-text").focus(); return; }
  if (!textFits() || !expressionsKnown()) return;
  setSource("speaking");
  $("latency").textContent = "…";
  await player.speak({ text: t, lang: $("lang").value, project: S.project, blend: !!S.project.settings.blend });
}

async function remix(key) {
  syncText();
  try {
    return await api(`/api/speech/${key}/frames`, { method: "POST", body: { project: S.project, fps: 30, blend: !!S.project.settings.blend }, quiet: true });
  } catch (e) {
    if (e.status === 404) toast("The speech expired on the server; press Speak again.", "info");
    else toast(e.message);
    return null;
  }
}

async function play() {
  if (!expressionsKnown()) return;
  await sampled();
  setSource("playing");
  // the playhead still where the last playback ended: play again from the start
  await player.play(editor.time === S.endedAt ? 0 : editor.time, remix);
}

function togglePlay() { if (player.mode === "idle") play(); else player.stop(); }

function loop() {
  const t = player.clock();
  if (t !== null && t >= 0) {
    if (player.finished(t)) {
      player.stop();
      S.endedAt = editor.time;
    } else {
      viewer.apply(player.frameAt(t));
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

// -- start ---------------------------------------------------------------------------------------
function buildLayerSwitches() {
  const box = $("layers");
  for (const l of LAYERS) {
    box.append(el("label", { class: "check" }, el("input", { type: "checkbox", value: l, checked: true,
      onchange: () => { S.project.settings.behaviour = [...box.querySelectorAll("input:checked")].map((x) => x.value); commit(); } }),
    LAYER_LABEL[l]));
  }
}

function buildHeadPicker(heads) {
  const sel = $("head-select");
  sel.innerHTML = "";
  for (const h of heads) {
    sel.append(el("option", { value: h.name, disabled: !h.available, title: h.description },
      h.available ? h.name : `${h.name} (not installed)`));
  }
  sel.title = "The head to animate; the list comes from mimika's heads (mimika heads)";
  sel.addEventListener("change", async () => {
    const name = sel.value;
    try {
      await useHead(name);
      S.project.settings.head = name;
      commit();
    } catch (e) { toast(e.message); }
  });
}

async function main() {
  viewer = new Viewer($("view"));
  if (viewer.error) toast(viewer.error, "info");
  const [status, heads, look] = await Promise.all([api("/api/status"), api("/api/heads"), api("/api/look")]);
  S.status = status;
  S.maxText = (status.limits && status.limits.max_text) || 5000;
  S.heads = heads.heads;
  viewer.setLookInfo(look);
  viewer.onViewChange = (v) => setView(v);
  $("btn-export-mp4").title = status.features.mp4 ? "H.264 video with the speech (rendered on the server)" : status.features.mp4_reason;
  buildHeadPicker(heads.heads);
  buildLayerSwitches();
  const info = await api(`/api/head?name=${encodeURIComponent(heads.default)}`);
  panel = new AUPanel($("au-groups"), info.groups, { onChange: onPose, onCommit: commit });
  library = new LibraryPanel({ list: $("expr-list"), filter: $("expr-filter"), nameInput: $("expr-name"), saveBtn: $("btn-expr-save"),
    onApply: (e) => { panel.setPose(e.aus); commit(); }, onAdd: (e) => editor.addExpression(e.name), getPose: () => panel.pose(),
    onRefresh: () => { if (editor && editor.project) { editor.render(); editor.renderParams(); resample(); } } });
  blender = new BlenderPanel({ list: $("rules"), filter: $("rule-filter"), trace: $("trace"),
    onChange: (off) => { S.project.settings.blender_off = off; runBlend(); resample(); commit(); } });
  player = new Player({ audio: $("audio"),
    onSentence: (sents) => { editor.words = sents.flatMap((s) => s.words); editor.speechEnd = Math.max(...sents.map((s) => s.end)); editor.render(); },
    onState: (mode) => { $("btn-play").textContent = mode === "idle" ? "Play" : "Pause"; if (mode === "idle" && S.source !== "designer") setSource("timeline"); },
    onLatency: showLatency });
  player.onError = (msg) => toast(/^internal error/i.test(msg) ? "Speaking failed inside the studio server (its log has the details); press Speak again." : sentence(msg));
  editor = new TimelineEditor({ heads: $("tl-heads"), scroll: $("tl-scroll"), canvas: $("tl-canvas"), ruler: $("tl-ruler"),
    lanes: $("tl-lanes"), playhead: $("tl-playhead"), knob: $("tl-knob"), params: $("param-body"), easings: status.easings,
    onChange: () => resample(), onSeek: seek, onCommit: commit,
    expressionNames: () => library.names(), hasExpression: (n) => library.has(n), defaultExpression: () => "happiness" });
  const useRecording = (r, name) => { player.loadSpeech(r, name); setSource("timeline"); seek(0); };
  const recordingKey = () => (player.recording ? player.key : null);
  files = new Files({ S, syncText, text, textFits, expressionsKnown, loadProject, markSaved, currentPose, useRecording, recordingKey });
  history = new History(snapshot, { onChange: (h) => { $("btn-undo").disabled = !h.canUndo; $("btn-redo").disabled = !h.canRedo; } });
  S.head = heads.default;
  $("head-select").value = S.head;
  await Promise.all([viewer.load(`/api/head.glb?name=${encodeURIComponent(S.head)}`, info), library.refresh(), files.refreshList(), blender.load()]);
  await setProject(emptyProject(), { name: "" });
  history.reset();
  markSaved(S.project);
  latent = new LatentPanel({ status: $("latent-status"), box: $("latent-sliders"), labelRow: $("latent-label-row"),
    labelSelect: $("latent-label"), onPose: (aus) => panel.setPose(aus), onCommit: commit });
  latent.init().catch(() => {});

  const on = (id, ev, fn) => $(id).addEventListener(ev, (e) => { Promise.resolve(fn(e)).catch((err) => toast(err.message || String(err))); });
  on("btn-speak", "click", speak);
  on("btn-play", "click", togglePlay);
  on("btn-stop", "click", () => player.stop());
  on("btn-save", "click", () => files.save());
  on("btn-load", "click", () => files.open($("project-list").value));
  on("btn-new", "click", () => loadProject(emptyProject(""), "", "Started a new project."));
  on("btn-import", "click", () => $("import-file").click());
  on("btn-recording", "click", () => $("recording-file").click());
  on("recording-file", "change", async (e) => { const f = e.target.files[0]; e.target.value = ""; if (f) await files.importRecording(f); });
  on("import-file", "change", async (e) => { const f = e.target.files[0]; e.target.value = ""; if (f) await files.importFile(f); });
  on("btn-undo", "click", undo);
  on("btn-redo", "click", redo);
  on("btn-reset", "click", () => { panel.setPose({}); commit(); });
  on("btn-export-gltf", "click", () => files.exportAs("gltf"));
  on("btn-export-csv", "click", () => files.exportAs("csv"));
  on("btn-export-mp4", "click", () => files.exportAs("mp4"));
  on("btn-export-png", "click", () => files.exportPng());
  on("btn-export-sheet", "click", () => files.exportSheet());
  on("btn-export-project", "click", () => files.exportProject());
  on("opt-blend", "change", () => { S.project.settings.blend = $("opt-blend").checked; runBlend(); showPose(); resample(); commit(); });
  on("look-select", "change", () => { S.project.settings.look = $("look-select").value; viewer.setLook(S.project.settings.look); commit(); });
  for (const b of document.querySelectorAll("#view-tools [data-view]")) b.addEventListener("click", () => setView(b.dataset.view));
  const commitText = debounce(commit, 700);
  on("speech-text", "input", () => { forgetSpeech(); showCount(); syncText(); resample(); commitText(); updateDirty(); });
  on("speech-text", "change", () => commitText.flush());
  on("lang", "change", () => { forgetSpeech(); commit(); });
  on("project-name", "input", () => { $("project-name").removeAttribute("aria-invalid"); updateDirty(); });
  on("zoom-in", "click", () => editor.zoom(1.25));
  on("zoom-out", "click", () => editor.zoom(0.8));
  setupTabs(document.querySelector("[role=tablist]"));
  setupMenus();
  setupKeys({ save: () => files.save(), undo, redo, remove: () => editor.remove(), togglePlay, hasSelection: () => !!editor.sel });
  window.addEventListener("beforeunload", (e) => { if (dirty()) { e.preventDefault(); e.returnValue = ""; } });
  requestAnimationFrame(loop);
  window.mimikaStudio.readyAt = performance.now();
  window.mimikaStudio.ready = true;
}

window.mimikaStudio = {
  ready: false,
  get viewer() { return viewer; }, get player() { return player; }, get editor() { return editor; },
  get panel() { return panel; }, get project() { return S.project; }, get history() { return history; },
  get latent() { return latent; }, state: S,
  weights: () => viewer.weights(),
  metrics: () => ({ ...player.metrics }),
  audio: () => $("audio"),
  clock: () => player.clock(),
  dirty: () => dirty(),
  NAME_RE,
};
main().catch((e) => { console.warn(e); toast(`The studio could not start: ${e.message}`); });
