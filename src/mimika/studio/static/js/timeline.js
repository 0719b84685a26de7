// The multi-track timeline editor (seed 004's animation editor over mimika's Timeline):
// tracks = channels; triggers can be dragged, resized and edited in the trigger panel.
import { el, fmt } from "./ui.js";

const DIRS = {
  gaze: ["left", "right", "up", "down", "up-left", "up-right", "down-left", "down-right", "ahead"],
  turn: ["left", "right", "up", "down", "ahead"], tilt: ["left", "right"], blink: ["both", "left", "right"],
};
const HEAD_KINDS = ["nod", "shake", "turn", "tilt"];
const MIN_DUR = 0.1, SNAP = 0.02;

export const TRACKS = [
  { id: "speech", label: "Speech", channel: null },
  { id: "face", label: "Expressions", channel: "face" },
  { id: "head", label: "Head", channel: "head" },
  { id: "gaze", label: "Gaze", channel: "gaze" },
  { id: "blink", label: "Blinks", channel: "blink" },
];

const snap = (t) => Math.round(t / SNAP) * SNAP;
const clamp = (x, lo, hi) => Math.min(Math.max(x, lo), hi);

export class TimelineEditor {
  constructor({ heads, scroll, canvas, ruler, lanes, playhead, params, onChange, onSeek, easings,
                expressionNames, defaultExpression }) {
    Object.assign(this, { heads, scroll, canvas, ruler, lanes, playhead, params, onChange, onSeek });
    this.easings = easings || ["linear", "cosine", "smoothstep"];
    this.expressionNames = expressionNames;   // () → [names]
    this.defaultExpression = defaultExpression; // () → name
    this.pps = 110;  // pixels per second
    this.time = 0;
    this.words = [];
    this.speechEnd = 0;
    this.sel = null;  // {channel, ev}
    this.project = null;
    this.ruler.addEventListener("pointerdown", (e) => this.seekAt(e));
    this.lanes.addEventListener("pointerdown", (e) => { if (e.target.classList.contains("lane")) { this.select(null); this.seekAt(e); } });
  }

  setProject(project) { this.project = project; this.sel = null; this.render(); this.renderParams(); }

  channel(name, create = false) {
    const chans = this.project.timeline.channels;
    let c = chans.find((x) => x.name === name);
    if (!c && create) {
      c = { name, override: false, ease: "cosine", bridge: null, events: [] };
      chans.push(c);
      chans.sort((a, b) => a.name.localeCompare(b.name));
    }
    return c;
  }

  tracks() {
    const known = new Set(TRACKS.map((t) => t.channel));
    const extra = this.project.timeline.channels.filter((c) => !known.has(c.name))
      .map((c) => ({ id: c.name, label: c.name, channel: c.name }));
    return [...TRACKS, ...extra];
  }

  end() {
    let end = this.speechEnd;
    for (const c of this.project.timeline.channels) for (const e of c.events) end = Math.max(end, e.start + e.duration);
    return end;
  }

  secAt(clientX) { const r = this.canvas.getBoundingClientRect(); return Math.max(0, (clientX - r.left) / this.pps); }
  seekAt(e) { this.onSeek(snap(this.secAt(e.clientX))); }

  setTime(t) {
    this.time = t;
    this.playhead.style.left = `${t * this.pps}px`;
    const x = t * this.pps, sl = this.scroll.scrollLeft, w = this.scroll.clientWidth;
    if (x > sl + w - 40 || x < sl) this.scroll.scrollLeft = Math.max(0, x - w * 0.2);
  }

  zoom(f) { this.pps = clamp(this.pps * f, 20, 600); this.render(); }

  render() {
    const tracks = this.tracks();
    const width = (Math.max(this.end(), 8) + 4) * this.pps;
    this.canvas.style.width = `${width}px`;
    // ruler
    this.ruler.innerHTML = "";
    const step = this.pps >= 160 ? 0.5 : this.pps >= 60 ? 1 : 2;
    for (let t = 0; t * this.pps < width; t += step) {
      this.ruler.append(el("div", { class: "tick", style: `left:${t * this.pps}px` }, Number.isInteger(t) ? `${t}s` : ""));
    }
    // heads + lanes
    this.heads.innerHTML = "";
    this.lanes.innerHTML = "";
    for (const tr of tracks) {
      this.heads.append(el("div", { class: "tl-head", dataset: { track: tr.id } }, el("span", {}, tr.label),
        tr.channel ? el("button", { class: "small", title: `add a trigger to ${tr.label} at the playhead`,
          "aria-label": `add to ${tr.label}`, onclick: () => this.add(tr) }, "+") : null));
      const lane = el("div", { class: "lane", dataset: { track: tr.id } });
      if (tr.id === "speech") {
        for (const w of this.words) {
          lane.append(el("div", { class: "ev word", style: `left:${w.start * this.pps}px;width:${Math.max(2, (w.end - w.start) * this.pps)}px`, title: w.text },
            el("span", { class: "lbl" }, w.text)));
        }
      } else {
        const ch = this.channel(tr.channel);
        for (const ev of ch ? ch.events : []) lane.append(this.eventEl(tr.channel, ev));
      }
      this.lanes.append(lane);
    }
    this.setTime(this.time);
  }

  label(ev) {
    if (ev.kind === "expression") return ev.name;
    if (ev.kind === "aus") return ev.aus.map(([c, v]) => `${c}=${fmt(v)}`).join(" ");
    if (ev.kind === "nod" || ev.kind === "shake") return ev.kind + ((ev.count || 1) > 1 ? `×${ev.count}` : "");
    return `${ev.kind} ${ev.name || ""}`;
  }

  eventEl(channel, ev) {
    const d = ev.duration, on = ev.onset ?? 0, off = ev.offset ?? 0, k = ev.intensity ?? 1;
    const a = (on / d) * 100, b = 100 - (off / d) * 100;
    const shade = `linear-gradient(90deg, rgba(0,0,0,.45) 0%, rgba(0,0,0,${0.45 * (1 - k)}) ${a}%, rgba(0,0,0,${0.45 * (1 - k)}) ${b}%, rgba(0,0,0,.45) 100%)`;
    const div = el("div", {
      class: `ev k-${ev.kind}${this.sel && this.sel.ev === ev ? " sel" : ""}`,
      style: `left:${ev.start * this.pps}px;width:${Math.max(6, d * this.pps)}px`,
      title: `${this.label(ev)} — ${fmt(ev.start)}–${fmt(ev.start + d)} s, intensity ${fmt(k)}`,
      dataset: { channel, start: ev.start },
    }, el("div", { class: "ramp", style: `background:${shade}` }), el("span", { class: "lbl" }, this.label(ev)),
      el("div", { class: "h l" }), el("div", { class: "h r" }));
    div.addEventListener("pointerdown", (e) => this.startDrag(e, channel, ev, div));
    return div;
  }

  // free interval [lo, hi] around ev in its channel
  room(channel, ev) {
    let lo = 0, hi = Infinity;
    for (const o of this.channel(channel).events) {
      if (o === ev) continue;
      if (o.start + o.duration <= ev.start + 1e-9) lo = Math.max(lo, o.start + o.duration);
      else if (o.start >= ev.start + ev.duration - 1e-9) hi = Math.min(hi, o.start);
    }
    return [lo, hi];
  }

  startDrag(e, channel, ev, div) {
    e.preventDefault();
    e.stopPropagation();
    this.sel = { channel, ev };
    for (const d of this.lanes.querySelectorAll(".ev.sel")) d.classList.remove("sel");
    div.classList.add("sel");
    this.renderParams();
    const mode = e.target.classList.contains("l") ? "l" : e.target.classList.contains("r") ? "r" : "move";
    const x0 = e.clientX, s0 = ev.start, d0 = ev.duration, end0 = s0 + d0;
    const [lo, hi] = this.room(channel, ev);
    div.setPointerCapture(e.pointerId);
    div.style.cursor = mode === "move" ? "grabbing" : "ew-resize";
    const move = (m) => {
      const dt = (m.clientX - x0) / this.pps;
      if (mode === "move") ev.start = clamp(snap(s0 + dt), lo, hi - d0);
      else if (mode === "r") ev.duration = clamp(snap(d0 + dt), MIN_DUR, hi - s0);
      else { ev.start = clamp(snap(s0 + dt), lo, end0 - MIN_DUR); ev.duration = end0 - ev.start; }
      this.fitRamps(ev);
      div.style.left = `${ev.start * this.pps}px`;
      div.style.width = `${ev.duration * this.pps}px`;
    };
    const up = () => {
      div.removeEventListener("pointermove", move);
      div.removeEventListener("pointerup", up);
      div.removeEventListener("pointercancel", up);
      ev.start = Math.round(ev.start * 1000) / 1000;
      ev.duration = Math.round(ev.duration * 1000) / 1000;
      if (ev.start !== s0 || ev.duration !== d0) { delete ev.anchor; delete ev.at; this.changed(); }
    };
    div.addEventListener("pointermove", move);
    div.addEventListener("pointerup", up);
    div.addEventListener("pointercancel", up);
  }

  fitRamps(ev) {
    const on = ev.onset ?? 0, off = ev.offset ?? 0;
    if (on + off > ev.duration) {
      const k = ev.duration / (on + off);
      if (ev.onset != null) ev.onset = Math.floor(ev.onset * k * 1000) / 1000;
      if (ev.offset != null) ev.offset = Math.floor(ev.offset * k * 1000) / 1000;
    }
  }

  changed() {
    for (const c of this.project.timeline.channels) c.events.sort((a, b) => a.start - b.start);
    this.render();
    this.renderParams();
    this.onChange();
  }

  select(sel) {
    this.sel = sel;
    for (const d of this.lanes.querySelectorAll(".ev.sel")) d.classList.remove("sel");
    this.render();
    this.renderParams();
  }

  add(track) {
    const ch = this.channel(track.channel, true);
    let ev;
    if (track.channel === "face") ev = { kind: "expression", name: this.defaultExpression() || "happiness", duration: 1.5, intensity: 0.8 };
    else if (track.channel === "head") ev = { kind: "nod", duration: 0.6, intensity: 0.6 };
    else if (track.channel === "gaze") ev = { kind: "gaze", name: "left", duration: 1.0, intensity: 0.6 };
    else if (track.channel === "blink") ev = { kind: "blink", name: "both", duration: 0.3 };
    else ev = { kind: "expression", name: this.defaultExpression() || "happiness", duration: 1.0 };
    // first free slot at or after the playhead
    let t = snap(this.time);
    for (const o of [...ch.events].sort((a, b) => a.start - b.start)) {
      if (o.start + o.duration > t && o.start < t + ev.duration) t = o.start + o.duration;
    }
    ev.start = Math.round(t * 1000) / 1000;
    ch.events.push(ev);
    this.sel = { channel: ch.name, ev };
    this.changed();
    return ev;
  }

  addExpression(name, intensity = 0.8, duration = 1.5) {
    const ev = this.add(TRACKS[1]);
    ev.name = name; ev.intensity = intensity; ev.duration = duration;
    this.changed();
  }

  remove() {
    if (!this.sel) return;
    const ch = this.channel(this.sel.channel);
    ch.events = ch.events.filter((e) => e !== this.sel.ev);
    this.sel = null;
    this.changed();
  }

  renderParams() {
    const body = this.params;
    body.innerHTML = "";
    if (!this.sel) { body.className = "muted"; body.textContent = "Select a trigger on the timeline, or add one with +."; return; }
    body.className = "";
    const { channel, ev } = this.sel;
    const update = () => { delete ev.anchor; delete ev.at; this.fitRamps(ev); this.changed(); };
    const range = (label, key, min, max, step, dflt, id) => {
      const v = ev[key] ?? dflt;
      const out = el("output", {}, ev[key] == null && key !== "intensity" ? "auto" : fmt(v));
      const inp = el("input", { type: "range", min, max, step, value: v, id,
        oninput: (e) => { out.textContent = fmt(e.target.value); },
        onchange: (e) => { ev[key] = Number(e.target.value); update(); } });
      return el("div", { class: "prm" }, el("label", { for: id }, label), inp, out);
    };
    const select = (label, options, value, set, id) => el("div", { class: "prm" }, el("label", { for: id }, label),
      el("select", { id, onchange: (e) => { set(e.target.value); update(); } },
        options.map((o) => el("option", { value: o, selected: o === value }, o))));
    const end = this.room(channel, ev)[1];
    body.append(el("div", { class: "prm" }, el("label", {}, "track"), el("span", {}, channel), el("span")));
    if (channel === "head" || HEAD_KINDS.includes(ev.kind)) {
      body.append(select("kind", HEAD_KINDS, ev.kind, (k) => {
        ev.kind = k;
        if (DIRS[k]) ev.name = DIRS[k][0]; else delete ev.name;
      }, "p-kind"));
    }
    if (ev.kind === "expression") body.append(select("expression", this.expressionNames(), ev.name, (n) => { ev.name = n; }, "p-name"));
    else if (DIRS[ev.kind]) body.append(select("direction", DIRS[ev.kind], ev.name, (n) => { ev.name = n; }, "p-name"));
    body.append(range("start", "start", 0, Math.max(ev.start + 5, this.end() + 2), 0.01, 0, "p-start"));
    body.append(range("duration", "duration", MIN_DUR, Math.min(Math.max(ev.duration * 2, 4), end - ev.start), 0.01, 1, "p-duration"));
    body.append(range("intensity", "intensity", 0, 1, 0.01, 1, "p-intensity"));
    body.append(range("ease-in", "onset", 0, ev.duration, 0.01, 0, "p-onset"));
    body.append(range("ease-out", "offset", 0, ev.duration, 0.01, 0, "p-offset"));
    body.append(select("easing", ["(channel)", ...this.easings], ev.ease || "(channel)", (v) => {
      if (v === "(channel)") delete ev.ease; else ev.ease = v;
    }, "p-ease"));
    if (ev.kind === "nod" || ev.kind === "shake") body.append(range("count", "count", 1, 5, 1, 1, "p-count"));
    body.append(el("div", { class: "row", style: "margin-top:6px" },
      el("button", { onclick: () => this.remove(), id: "p-delete" }, "Delete trigger")));
  }
}
