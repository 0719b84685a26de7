// Projects and exports: save/open/new, import and export of project files, glTF/CSV/MP4/PNG
// exports (one at a time per kind, with a cancel button for long ones).
import { api, download, saveBlob, sentence } from "./api.js";
import { el, toast } from "./ui.js";

const $ = (id) => document.getElementById(id);
// letters and digits of any script, '-', '_' and inner spaces (mimika.studio.names)
export const NAME_RE = /^[\p{L}\p{N}_-](?:[\p{L}\p{N} _-]{0,62}[\p{L}\p{N}_-])?$/u;

export class Files {
  constructor(app) {
    this.app = app;
    this.busy = new Map();  // export kind → AbortController
  }

  projectName({ quiet = false } = {}) {
    const inp = $("project-name");
    const name = inp.value.trim().normalize("NFC");
    const bad = !name ? "Give the project a name first."
      : !NAME_RE.test(name) ? `“${name}” cannot be a project name: use up to 64 letters, digits, '-', '_' or spaces between them (no dots or slashes).`
        : null;
    if (bad) {
      if (!quiet) { inp.setAttribute("aria-invalid", "true"); toast(bad); inp.focus(); }
      return null;
    }
    inp.removeAttribute("aria-invalid");
    return name;
  }

  async save() {
    const name = this.projectName();
    if (!name || !this.app.expressionsKnown()) return;
    this.app.syncText();
    const doc = JSON.parse(JSON.stringify(this.app.S.project));
    const r = await api(`/api/projects/${encodeURIComponent(name)}`, { method: "PUT", body: doc }).catch(() => null);
    if (!r) return;
    this.app.markSaved(doc);
    toast(`Saved “${r.saved}”.`, "ok", 2500);
    await this.refreshList(r.saved);
  }

  async open(name) {
    if (!name) { toast("Choose a saved project to open."); $("project-list").focus(); return; }
    const p = await api(`/api/projects/${encodeURIComponent(name)}`).catch(() => null);
    if (!p) return;
    const ok = await this.app.loadProject(p, name, `Opened “${name}”.`);
    if (ok) this.app.markSaved(this.app.S.project);
  }

  async refreshList(selected) {
    const r = await api("/api/projects", { quiet: true }).catch(() => ({ projects: [] }));
    const sel = $("project-list");
    sel.innerHTML = "";
    sel.append(el("option", { value: "" }, r.projects.length ? "— saved projects —" : "— no saved projects —"));
    for (const p of r.projects) sel.append(el("option", { value: p.name, selected: p.name === selected }, p.name));
  }

  // A project file from the user's computer: checked by the server, then opened (undoable).
  async importFile(file) {
    let doc;
    try {
      doc = JSON.parse(await file.text());
    } catch {
      toast(`“${file.name}” is not a mimika project file: it does not contain JSON.`);
      return;
    }
    const r = await api("/api/projects/check", { method: "POST", body: doc }).catch(() => null);
    if (!r) return;
    if (!r.ok) {
      toast(`“${file.name}” cannot be opened:\n• ${r.problems.slice(0, 6).map(sentence).join("\n• ")}`);
      return;
    }
    const base = file.name.replace(/\.json$/i, "").replace(/[^\p{L}\p{N} _-]+/gu, "-").replace(/^[ -]+|[ -]+$/g, "").slice(0, 64);
    await this.app.loadProject(r.project, base, `Opened “${file.name}”. Save it to keep it in the studio.`);
  }

  exportProject() {
    this.app.syncText();
    const text = JSON.stringify(this.app.S.project, null, 2) + "\n";
    const name = `${this.fileStem()}.json`;
    saveBlob(new Blob([text], { type: "application/json" }), name);
    toast(`Saved ${name} to your downloads.`, "ok", 2500);
  }

  // a file name for downloads (any script), and an ASCII one for the server
  fileStem() { return ($("project-name").value.trim().normalize("NFC").replace(/[^\p{L}\p{N}_-]+/gu, "-").replace(/^-+|-+$/g, "")) || "mimika"; }
  serverName() { return this.fileStem().replace(/[^A-Za-z0-9_-]+/g, "-").replace(/^-+|-+$/g, "") || "mimika"; }

  // Run one export of ``kind`` (button disabled meanwhile; long ones can be cancelled).
  async run(kind, btn, work, { what, slow = false }) {
    if (this.busy.has(kind)) return;
    const ctl = new AbortController();
    this.busy.set(kind, ctl);
    btn.disabled = true;
    btn.setAttribute("aria-busy", "true");
    const note = toast(`${what}…${slow ? " (this can take a minute)" : ""}`, "info", 0,
      slow ? { label: "Cancel", run: () => ctl.abort() } : null);
    try {
      const size = await work(ctl.signal);
      if (size) toast(`${what} done: ${(size / 1024).toFixed(0)} KiB in your downloads.`, "ok", 3000);
    } catch (e) {
      if (e.status === -1) toast(`${what} cancelled.`, "info", 3000);
      else if (e.status === undefined) toast(String(e.message || e));
      // ApiErrors were shown already
    } finally {
      note.close();
      this.busy.delete(kind);
      btn.disabled = false;
      btn.removeAttribute("aria-busy");
    }
  }

  body() {
    const { S } = this.app;
    this.app.syncText();
    const empty = !S.project.timeline.channels.some((c) => c.events.length) && !this.app.text().trim();
    const usePose = S.source === "designer" && empty;
    const st = S.project.settings;
    const rec = this.app.recordingKey();
    return usePose ? { aus: this.app.currentPose(), name: this.serverName(), fps: 30, head: st.head, view: st.view, look: st.look || "plain" }
      : { project: S.project, name: this.serverName(), fps: 30, ...(rec ? { speech_key: rec } : {}) };
  }

  // A recording of the text: decoded and resampled here (any format the browser plays),
  // aligned on the server; then Play, the subtitles and the exports use it.
  async importRecording(file) {
    const { S } = this.app;
    this.app.syncText();
    const text = this.app.text();
    if (!text.trim()) { toast("Type the words of the recording into the text box first: the studio lines the mouth up with them."); return; }
    if (!this.app.textFits()) return;
    let pcm;
    try {
      const decoded = await new AudioContext().decodeAudioData(await file.arrayBuffer());
      const sr = 22050, n = Math.ceil(decoded.duration * sr);
      const off = new OfflineAudioContext(1, n, sr);
      const src = off.createBufferSource();
      src.buffer = decoded;
      src.connect(off.destination);
      src.start();
      const mono = (await off.startRendering()).getChannelData(0);
      pcm = new Int16Array(n);
      for (let i = 0; i < n; i++) pcm[i] = Math.max(-32768, Math.min(32767, Math.round(mono[i] * 32767)));
    } catch {
      toast(`“${file.name}” is not a recording this browser can read: use WAV, MP3, OGG or another audio format.`);
      return;
    }
    const head = new TextEncoder().encode(JSON.stringify({ text, lang: S.project.settings.lang, sr: 22050,
      project: S.project, blend: !!S.project.settings.blend }));
    const room = S.status.limits.max_body - head.length - 4;
    if (pcm.byteLength > room) {
      toast(`“${file.name}” is ${(pcm.length / 22050).toFixed(0)} s long; the studio takes recordings of up to ${(room / 2 / 22050).toFixed(0)} s at a time. Cut it into parts.`);
      return;
    }
    const body = new Uint8Array(4 + head.length + pcm.byteLength);
    new DataView(body.buffer).setUint32(0, head.length, true);
    body.set(head, 4);
    body.set(new Uint8Array(pcm.buffer), 4 + head.length);
    await this.run("recording", $("btn-recording"), async () => {
      const r = await api("/api/speech/align", { method: "POST", body });
      this.app.useRecording(r, file.name);
      toast(`The mouth now follows “${file.name}” (${r.duration.toFixed(1)} s). Press Play.`, "ok", 4000);
      return 0;
    }, { what: `Lining up the mouth with “${file.name}”` });
  }

  async exportAs(kind) {
    const { S } = this.app;
    if (kind === "mp4" && !S.status.features.mp4) {
      toast(`${sentence(S.status.features.mp4_reason || "MP4 export isn't available")} Export glTF or CSV instead.`);
      return;
    }
    if (!this.app.textFits() || !this.app.expressionsKnown()) return;
    const body = this.body();
    if (kind === "csv") body.format = $("csv-format").value;
    const ext = { gltf: "glb", csv: "csv", mp4: "mp4" }[kind];
    const file = `${this.fileStem()}.${ext}`;
    const what = { gltf: `Exporting ${file}`, csv: `Exporting ${file}`, mp4: `Rendering ${file}` }[kind];
    await this.run(kind, $(`btn-export-${kind}`), (signal) => download(`/api/export/${kind}`, body, file, { signal }),
      { what, slow: kind === "mp4" });
  }

  async exportPng() {
    const { S } = this.app;
    const st = S.project.settings;
    const [width, height] = st.size || [640, 480];
    const body = { aus: S.pose, head: st.head, view: st.view, look: st.look || "plain", width, height,
      blend: !!st.blend, disabled: st.blender_off || [] };
    const file = `${this.fileStem()}-pose.png`;
    await this.run("png", $("btn-export-png"), (signal) => download("/api/export/png", body, file, { signal }),
      { what: `Drawing ${file}` });
  }

  async exportSheet() {
    const st = this.app.S.project.settings;
    const file = `${this.fileStem()}-library.png`;
    await this.run("sheet", $("btn-export-sheet"), (signal) => download("/api/export/sheet",
      { head: st.head, view: st.view, look: st.look || "plain" }, file, { signal }),
    { what: `Drawing the library into ${file}`, slow: true });
  }
}
