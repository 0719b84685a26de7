// The multi-track timeline editor (seed 004's animation editor over mimika's Timeline):
// tracks = channels; triggers are dragged, resized, moved with the keyboard and edited in the
// trigger panel — always inside the free room of their track, so triggers never overlap.
// The playhead is dragged on the ruler or moved with the keyboard.
import { el, fmt } from "./ui.js";

const DIRS = {
  gaze: ["left", "right", "up", "down", "up-left", "up-right", "down-left", "down-right", "ahead"],
  turn: ["left", "right", "up", "down", "ahead"], tilt: ["left", "right"], blink: ["both", "left", "right"],
};
const HEAD_KINDS = ["nod", "shake", "turn", "tilt"];
const MIN_DUR = 0.1, SNAP = 0.02, MAX_TIME = 600;

export const TRACKS = [
  { id: "speech", label: "Speech", channel: null },
  { id: "face", label: "Expressions", channel: "face" },
  { id: "head", label: "Head", channel: "head" },
  { id: "gaze", label: "Gaze", channel: "gaze" },
  { id: "blink", label: "Blinks", channel: "blink" },
];

const snap = (t) => Math.round(t / SNAP) * SNAP;
const clamp = (x, lo, hi) => Math.min(Math.max(x, lo), hi);
const r3 = (x) => Math.round(x * 1000) / 1000;

export class TimelineEditor {
  constructor(o) {
    Object.assign(this, o);  // heads, scroll, canvas, ruler, lanes, playhead, knob, params, on…
    this.easings = o.easings || ["linear", "cosine", "smoothstep"];
    this.pps = 110;  // pixels per second
    this.time = 0;
    this.words = [];
    this.speechEnd = 0;
    this.sel = null;  // {channel, ev}
    this.project = null;
    this.evEls = new Map();
    this.scrubber(this.ruler);
    this.scrubber(this.knob);
    this.lanes.addEventListener("pointerdown", (e) => {
      if (!e.target.classList.contains("lane")) return;
      this.select(null);
      this.scrub(e, e.target);
    });
    this.knob.addEventListener("keydown", (e) => this.knobKey(e));
    this.scroll.addEventListener("scroll", () => { this.heads.scrollTop = this.scroll.scrollTop; });
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

  trackLabel(channel) { return (this.tracks().find((t) => t.channel === channel) || { label: channel }).label; }

  end() {
    let end = this.speechEnd;
    for (const c of this.project.timeline.channels) for (const e of c.events) end = Math.max(end, e.start + e.duration);
    return end;
  }

  // -- the playhead ---------------------------------------------------------------------------
  secAt(clientX) { const r = this.canvas.getBoundingClientRect(); return Math.max(0, (clientX - r.left) / this.pps); }

  scrubber(target) { target.addEventListener("pointerdown", (e) => this.scrub(e, target)); }

  // Seek where the pointer is, then follow it until it is released (drag to scrub).
  scrub(e, target) {
    if (e.button !== 0) return;
    e.preventDefault();
    this.onSeek(snap(this.secAt(e.clientX)));
    target.setPointerCapture(e.pointerId);
    const move = (m) => this.onSeek(snap(this.secAt(m.clientX)));
    const up = () => {
      target.removeEventListener("pointermove", move);
      target.removeEventListener("pointerup", up);
      target.removeEventListener("pointercancel", up);
    };
    target.addEventListener("pointermove", move);
    target.addEventListener("pointerup", up);
    target.addEventListener("pointercancel", up);
  }

  knobKey(e) {
    const step = e.shiftKey ? 1 : 0.1;
    const to = { ArrowLeft: this.time - step, ArrowDown: this.time - step, ArrowRight: this.time + step,
      ArrowUp: this.time + step, Home: 0, End: this.end(), PageDown: this.time - 1, PageUp: this.time + 1 }[e.key];
    if (to === undefined) return;
    e.preventDefault();
    this.onSeek(r3(Math.max(0, to)));
  }

  setTime(t) {
    this.time = t;
    this.playhead.style.left = `${t * this.pps}px`;
    this.knob.setAttribute("aria-valuenow", fmt(t));
    this.knob.setAttribute("aria-valuemax", fmt(Math.max(this.end(), t, 1)));
    this.knob.setAttribute("aria-valuetext", `${fmt(t)} seconds`);
    const x = t * this.pps, sl = this.scroll.scrollLeft, w = this.scroll.clientWidth;
    if (x > sl + w - 40 || x < sl) this.scroll.scrollLeft = Math.max(0, x - w * 0.2);
  }

  zoom(f) { this.pps = clamp(this.pps * f, 20, 600); this.render(); }

  // -- drawing --------------------------------------------------------------------------------
  render() {
    const focused = [...this.evEls].find(([, d]) => d === document.activeElement);
    const tracks = this.tracks();
    const width = Math.max((Math.max(this.end(), 8) + 4) * this.pps, this.scroll.clientWidth);
    this.canvas.style.width = `${width}px`;
    this.ruler.innerHTML = "";
    const step = this.pps >= 160 ? 0.5 : this.pps >= 60 ? 1 : 2;
    for (let t = 0; t * this.pps < width; t += step) {
      this.ruler.append(el("div", { class: "tick", style: `left:${t * this.pps}px` }, Number.isInteger(t) ? `${t}s` : ""));
    }
    this.heads.innerHTML = "";
    this.lanes.innerHTML = "";
    this.evEls = new Map();
    for (const tr of tracks) {
      this.heads.append(el("div", { class: "tl-head", dataset: { track: tr.id } }, el("span", {}, tr.label),
        tr.channel ? el("button", { class: "small", title: `add a trigger to ${tr.label} at the playhead`,
          "aria-label": `Add a trigger to ${tr.label}`, onclick: () => this.add(tr) }, "+") : null));
      const lane = el("div", { class: "lane", dataset: { track: tr.id }, role: "group", "aria-label": `${tr.label} track` });
      if (tr.id === "speech") {
        for (const w of this.words) {
          lane.append(el("div", { class: "ev word", style: `left:${w.start * this.pps}px;width:${Math.max(2, (w.end - w.start) * this.pps)}px`, title: w.text },
            el("span", { class: "lbl" }, w.text)));
        }
      } else {
        const ch = this.channel(tr.channel);
        for (const ev of ch ? ch.events : []) {
          const d = this.eventEl(tr.channel, ev);
          this.evEls.set(ev, d);
          lane.append(d);
        }
      }
      this.lanes.append(lane);
    }
    this.setTime(this.time);
    if (focused && this.evEls.has(focused[0])) this.evEls.get(focused[0]).focus({ preventScroll: true });
  }

  // Triggers naming an expression the library does not have: [{channel, index, ev}].
  missing() {
    const out = [];
    if (!this.project) return out;
    for (const c of this.project.timeline.channels) {
      c.events.forEach((ev, index) => { if (ev.kind === "expression" && !this.hasExpression(ev.name)) out.push({ channel: c.name, index, ev }); });
    }
    return out;
  }

  label(ev) {
    if (ev.kind === "expression") return ev.name;
    if (ev.kind === "aus") return ev.aus.map(([c, v]) => `${c}=${fmt(v)}`).join(" ");
    if (ev.kind === "nod" || ev.kind === "shake") return ev.kind + ((ev.count || 1) > 1 ? `×${ev.count}` : "");
    return `${ev.kind} ${ev.name || ""}`;
  }

  describe(channel, ev) {
    return `${this.label(ev)}, ${this.trackLabel(channel)} track, ${fmt(ev.start)} to ${fmt(ev.start + ev.duration)} seconds, intensity ${fmt(ev.intensity ?? 1)}`;
  }

  eventEl(channel, ev) {
    const d = ev.duration, on = ev.onset ?? 0, off = ev.offset ?? 0, k = ev.intensity ?? 1;
    const a = (on / d) * 100, b = 100 - (off / d) * 100;
    const shade = `linear-gradient(90deg, rgba(0,0,0,.45) 0%, rgba(0,0,0,${0.45 * (1 - k)}) ${a}%, rgba(0,0,0,${0.45 * (1 - k)}) ${b}%, rgba(0,0,0,.45) 100%)`;
    const selected = !!(this.sel && this.sel.ev === ev);
    const lost = ev.kind === "expression" && !this.hasExpression(ev.name);
    const div = el("div", {
      class: `ev k-${ev.kind}${selected ? " sel" : ""}${lost ? " missing" : ""}`, tabindex: 0, role: "button", "aria-pressed": String(selected),
      "aria-label": this.describe(channel, ev) + (lost ? ", not in your library" : ""),
      "aria-keyshortcuts": "ArrowLeft ArrowRight Alt+ArrowLeft Alt+ArrowRight Delete",
      style: `left:${ev.start * this.pps}px;width:${Math.max(6, d * this.pps)}px`,
      title: `${this.label(ev)} — ${fmt(ev.start)}–${fmt(ev.start + d)} s, intensity ${fmt(k)}. Drag to move, drag an edge to resize; ←/→ move, Alt+←/→ resize, Delete removes.`,
      dataset: { channel, start: ev.start },
    }, el("div", { class: "ramp", style: `background:${shade}` }), el("span", { class: "lbl" }, this.label(ev)),
      el("div", { class: "h l" }), el("div", { class: "h r" }));
    div.addEventListener("pointerdown", (e) => this.startDrag(e, channel, ev, div));
    div.addEventListener("focus", () => { if (!this.sel || this.sel.ev !== ev) this.select({ channel, ev }, false); });
    div.addEventListener("keydown", (e) => this.eventKey(e, channel, ev));
    return div;
  }

  // -- editing --------------------------------------------------------------------------------
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

  // Move ev (start changes) or resize it from its start (start unchanged), inside its room;
  // returns true when it changed.
  place(channel, ev, start, duration) {
    const [lo, hi] = this.room(channel, ev);
    const resize = start === ev.start;
    const d = r3(clamp(duration, MIN_DUR, Math.max(MIN_DUR, resize ? hi - ev.start : hi - lo)));
    const s = r3(clamp(start, lo, hi - d));
    if (s === ev.start && d === ev.duration) return false;
    ev.start = s; ev.duration = d;
    delete ev.anchor; delete ev.at;
    this.fitRamps(ev);
    return true;
  }

  eventKey(e, channel, ev) {
    const step = e.shiftKey ? 1 : 0.1;
    let done = false;
    if (e.key === "ArrowLeft" || e.key === "ArrowRight") {
      const dir = e.key === "ArrowLeft" ? -1 : 1;
      done = e.altKey ? this.place(channel, ev, ev.start, ev.duration + dir * step)
        : this.place(channel, ev, ev.start + dir * step, ev.duration);
      e.preventDefault();
    } else if (e.key === "Backspace") {
      e.preventDefault();
      this.remove();
      return;
    } else if (e.key === "Enter" || e.key === " ") {
      e.preventDefault();
      e.stopPropagation();
      this.select({ channel, ev }, false);
      return;
    } else if (e.key === "Escape") {
      this.select(null);
      return;
    }
    if (done) this.changed();
  }

  startDrag(e, channel, ev, div) {
    if (e.button !== 0) return;
    e.preventDefault();
    e.stopPropagation();
    this.sel = { channel, ev };
    for (const d of this.lanes.querySelectorAll(".ev.sel")) { d.classList.remove("sel"); d.setAttribute("aria-pressed", "false"); }
    div.classList.add("sel");
    div.setAttribute("aria-pressed", "true");
    div.focus({ preventScroll: true });
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
      ev.start = r3(ev.start);
      ev.duration = r3(ev.duration);
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

  // After every finished edit: redraw, resample, record for undo.
  changed() {
    for (const c of this.project.timeline.channels) c.events.sort((a, b) => a.start - b.start);
    this.render();
    this.renderParams();
    this.onChange();
    this.onCommit();
  }

  select(sel, redraw = true) {
    this.sel = sel;
    if (redraw) this.render();
    else {
      for (const [ev, d] of this.evEls) {
        const on = !!(sel && sel.ev === ev);
        d.classList.toggle("sel", on);
        d.setAttribute("aria-pressed", String(on));
      }
    }
    this.renderParams();
  }

  // The selected trigger, found again in a restored project (after undo/redo).
  reselect(channel, index) {
    const ch = this.channel(channel);
    const ev = ch && ch.events[index];
    this.select(ev ? { channel, ev } : null);
  }

  selection() {
    if (!this.sel) return null;
    const ch = this.channel(this.sel.channel);
    return ch ? { channel: this.sel.channel, index: ch.events.indexOf(this.sel.ev) } : null;
  }

  newEvent(channel) {
    if (channel === "face") return { kind: "expression", name: this.defaultExpression() || "happiness", duration: 1.5, intensity: 0.8 };
    if (channel === "head") return { kind: "nod", duration: 0.6, intensity: 0.6 };
    if (channel === "gaze") return { kind: "gaze", name: "left", duration: 1.0, intensity: 0.6 };
    if (channel === "blink") return { kind: "blink", name: "both", duration: 0.3 };
    return { kind: "expression", name: this.defaultExpression() || "happiness", duration: 1.0 };
  }

  // A new trigger in the first free slot at or after the playhead (shortened to fit a gap).
  add(track, ev = null) {
    const ch = this.channel(track.channel, true);
    ev = ev || this.newEvent(track.channel);
    let t = snap(this.time);
    const evs = [...ch.events].sort((a, b) => a.start - b.start);
    for (const o of evs) {
      if (o.start + o.duration > t && o.start < t + ev.duration) {
        if (o.start >= t + MIN_DUR) { ev.duration = r3(o.start - t); break; }  // fits in the gap
        t = o.start + o.duration;
      }
    }
    ev.start = r3(t);
    ch.events.push(ev);
    this.sel = { channel: ch.name, ev };
    this.changed();
    const d = this.evEls.get(ev);
    if (d) d.scrollIntoView({ block: "nearest", inline: "nearest" });
    return ev;
  }

  addExpression(name, intensity = 0.8, duration = 1.5) {
    return this.add(TRACKS[1], { kind: "expression", name, intensity, duration });
  }

  remove() {
    if (!this.sel) return false;
    const ch = this.channel(this.sel.channel);
    ch.events = ch.events.filter((e) => e !== this.sel.ev);
    this.sel = null;
    this.changed();
    return true;
  }

  // -- the trigger panel ----------------------------------------------------------------------
  renderParams() {
    const body = this.params;
    body.innerHTML = "";
    if (!this.sel) { body.className = "muted"; body.textContent = "Select a trigger on the timeline, or add one with +."; return; }
    body.className = "";
    const { channel, ev } = this.sel;
    const [lo, hi] = this.room(channel, ev);
    const update = () => { delete ev.anchor; delete ev.at; this.fitRamps(ev); this.changed(); };
    // a slider and a typed number for one value; set(x) applies it inside the limits
    const value = (label, key, min, max, step, dflt, set, typedMax = max) => {
      const v = ev[key] ?? dflt;
      const id = `p-${key}`;
      const num = el("input", { type: "number", min, max: typedMax, step, value: fmt(v), "aria-label": `${label} (number)`, id: `${id}-num` });
      const inp = el("input", { type: "range", min, max, step, value: v, id, "aria-valuetext": fmt(v),
        oninput: (e) => { num.value = fmt(e.target.value); e.target.setAttribute("aria-valuetext", fmt(e.target.value)); },
        onchange: (e) => { set(Number(e.target.value)); update(); } });
      num.addEventListener("change", () => {
        const x = Number(num.value);
        if (!Number.isFinite(x)) { num.value = fmt(v); return; }
        set(clamp(x, min, typedMax));
        update();
      });
      return el("div", { class: "prm" }, el("label", { for: id }, label), inp, num);
    };
    const select = (label, options, val, set, id) => el("div", { class: "prm" }, el("label", { for: id }, label),
      el("select", { id, onchange: (e) => { set(e.target.value); update(); } },
        options.map((o) => el("option", { value: o, selected: o === val }, o))));
    body.append(el("div", { class: "prm" }, el("span", { class: "muted" }, "track"), el("span", {}, this.trackLabel(channel)), el("span")));
    if (channel === "head" || HEAD_KINDS.includes(ev.kind)) {
      body.append(select("kind", HEAD_KINDS, ev.kind, (k) => {
        ev.kind = k;
        if (DIRS[k]) ev.name = DIRS[k][0]; else delete ev.name;
      }, "p-kind"));
    }
    if (ev.kind === "expression") {
      const names = this.expressionNames();
      body.append(select("expression", names.includes(ev.name) ? names : [ev.name, ...names], ev.name, (n) => { ev.name = n; }, "p-name"));
    } else if (DIRS[ev.kind]) body.append(select("direction", DIRS[ev.kind], ev.name, (n) => { ev.name = n; }, "p-name"));
    // start and duration stay inside the free room: no control can make triggers overlap
    const maxStart = Number.isFinite(hi) ? hi - ev.duration : Math.max(ev.start + 5, this.end() + 2);
    const free = (x) => (Number.isFinite(hi) ? x : MAX_TIME);  // typed values may go further
    body.append(value("start", "start", r3(lo), r3(Math.max(lo, maxStart)), 0.01, 0, (x) => { this.place(channel, ev, x, ev.duration); },
      r3(free(Math.max(lo, hi - ev.duration)))));
    const maxDur = Number.isFinite(hi) ? hi - ev.start : Math.max(ev.duration * 2, 4);
    body.append(value("duration", "duration", MIN_DUR, r3(Math.max(MIN_DUR, maxDur)), 0.01, 1, (x) => { this.place(channel, ev, ev.start, x); },
      r3(free(Math.max(MIN_DUR, hi - ev.start)))));
    body.append(value("intensity", "intensity", 0, 1, 0.01, 1, (x) => { ev.intensity = x; }));
    body.append(value("ease-in", "onset", 0, ev.duration, 0.01, 0, (x) => { ev.onset = x; }));
    body.append(value("ease-out", "offset", 0, ev.duration, 0.01, 0, (x) => { ev.offset = x; }));
    body.append(select("easing", ["(track)", ...this.easings], ev.ease || "(track)", (v) => {
      if (v === "(track)") delete ev.ease; else ev.ease = v;
    }, "p-ease"));
    if (ev.kind === "nod" || ev.kind === "shake") body.append(value("count", "count", 1, 5, 1, 1, (x) => { ev.count = Math.round(x); }));
    body.append(el("div", { class: "row", style: "margin-top:6px" },
      el("button", { onclick: () => this.remove(), id: "p-delete", "aria-keyshortcuts": "Delete" }, "Delete trigger")));
  }
}
