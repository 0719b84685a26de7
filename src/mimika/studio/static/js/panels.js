// Designer panels: AU sliders in FACS groups (with L/R split), the Blender trace, the
// expression library and the WGAN latent sliders.
import { api } from "./api.js";
import { el, fmt, debounce, toast } from "./ui.js";

const GROUP_TITLE = { "upper face": "Upper face", "lower face linear": "Lower face — linear",
  "lower face orbital": "Lower face — orbital", head: "Head", eyes: "Eyes" };

export class AUPanel {
  // onChange(pose) is called on every slider move with {code: value} (only non-zero codes)
  constructor(root, groups, onChange) {
    this.root = root;
    this.onChange = onChange;
    this.values = {};      // code → value, codes incl. L/R when split
    this.split = new Set(); // bilateral codes shown as L/R
    this.rows = {};
    this.sided = {};
    root.innerHTML = "";
    for (const g of groups) {
      const det = el("details", { class: "au-group", open: true, dataset: { group: g.name } },
        el("summary", {}, GROUP_TITLE[g.name] || g.name));
      for (const au of g.aus) {
        this.sided[au.code] = au.sided;
        const row = el("div", { class: "au-row", dataset: { au: au.code } });
        det.append(row);
        this.rows[au.code] = { row, au };
        this.renderRow(au.code);
      }
      root.append(det);
    }
  }

  slider(code, label) {
    const v = this.values[code] || 0;
    const out = el("output", {}, fmt(v));
    const inp = el("input", { type: "range", min: 0, max: 1, step: 0.01, value: v,
      "aria-label": code, dataset: { code },
      oninput: (e) => { this.set(code, Number(e.target.value), false); out.textContent = fmt(e.target.value); } });
    return [inp, out, label ? el("span", { class: "sub-label" }, label) : el("span")];
  }

  renderRow(code) {
    const { row, au } = this.rows[code];
    row.innerHTML = "";
    const split = this.split.has(code);
    const btn = au.sided ? el("button", { class: `side small${split ? " on" : ""}`,
      title: "separate left and right", "aria-label": `${code} left/right`,
      onclick: () => this.toggleSide(code) }, "L/R") : null;
    row.append(el("div", { class: "au-label" },
      el("span", {}, el("b", {}, code), el("span", { class: "name" }, au.name)), btn));
    if (split) {
      row.append(...this.slider(code + "L", "L"), ...this.slider(code + "R", "R"));
    } else {
      row.append(...this.slider(code));
    }
    const active = split ? (this.values[code + "L"] || this.values[code + "R"]) : this.values[code];
    row.classList.toggle("active", !!active);
  }

  toggleSide(code) {
    if (this.split.has(code)) {
      const v = Math.max(this.values[code + "L"] || 0, this.values[code + "R"] || 0);
      delete this.values[code + "L"]; delete this.values[code + "R"];
      this.split.delete(code);
      if (v) this.values[code] = v;
    } else {
      const v = this.values[code] || 0;
      delete this.values[code];
      this.split.add(code);
      if (v) { this.values[code + "L"] = v; this.values[code + "R"] = v; }
    }
    this.renderRow(code);
    this.onChange(this.pose());
  }

  set(code, v, redraw = true) {
    if (v > 0) this.values[code] = v; else delete this.values[code];
    const base = code.slice(0, 4);
    if (this.rows[base]) {
      if (redraw) this.renderRow(base);
      else this.rows[base].row.classList.toggle("active", Object.keys(this.values).some((c) => c.startsWith(base)));
    }
    this.onChange(this.pose());
  }

  // Set the whole pose (expression, latent sample); splits sides where a code needs it.
  setPose(aus) {
    this.values = {};
    this.split = new Set();
    for (const [code, v] of Object.entries(aus)) {
      const base = code.slice(0, 4);
      if (!this.rows[base] || v <= 0) continue;
      if (code.length > 4) this.split.add(base);
      this.values[code] = Math.round(v * 100) / 100;
    }
    for (const base of this.split) {  // a split AU keeps any bilateral value on both sides
      const v = this.values[base];
      if (v) { delete this.values[base]; for (const s of "LR") this.values[base + s] = Math.max(this.values[base + s] || 0, v); }
    }
    for (const code of Object.keys(this.rows)) this.renderRow(code);
    this.onChange(this.pose());
  }

  pose() { return { ...this.values }; }
}

export function showTrace(list, result, pose) {
  list.innerHTML = "";
  if (!Object.keys(pose).length) { list.append(el("li", { class: "muted" }, "all AUs at 0")); return; }
  if (!result.trace.length) { list.append(el("li", { class: "muted" }, "no rule changed anything")); return; }
  for (const t of result.trace) {
    const changes = Object.entries(t.outputs).map(([c, v]) =>
      `${c} ${fmt(t.inputs[c] ?? pose[c] ?? 0)}→${fmt(v)}`).join(", ");
    list.append(el("li", {}, el("code", {}, t.rule), " ", changes));
  }
}

export class ExpressionPanel {
  constructor({ list, filter, nameInput, saveBtn, onApply, onAdd, getPose }) {
    Object.assign(this, { list, filter, nameInput, onApply, onAdd, getPose });
    this.items = [];
    filter.addEventListener("input", () => this.render());
    saveBtn.addEventListener("click", () => this.save());
  }

  async refresh() {
    const data = await api("/api/expressions");
    this.items = data.expressions;
    this.render();
    return this.items;
  }

  names() { return this.items.map((e) => e.name); }

  render() {
    const q = this.filter.value.trim().toLowerCase();
    this.list.innerHTML = "";
    for (const e of this.items) {
      if (q && !e.name.includes(q)) continue;
      const aus = Object.entries(e.aus).map(([c, v]) => `${c.slice(2)}${v < 1 ? "·" + fmt(v, 1) : ""}`).join(" ");
      const li = el("li", { class: e.builtin ? "" : "user", dataset: { name: e.name }, title: e.description || aus },
        el("span", { class: "nm" }, e.name, el("small", {}, aus)),
        el("button", { onclick: () => this.onApply(e), title: "set the sliders" }, "Apply"),
        el("button", { onclick: () => this.onAdd(e), title: "add to the Expressions track at the playhead" }, "+TL"),
        e.builtin ? null : el("button", { onclick: () => this.remove(e.name), title: "delete" }, "✕"));
      this.list.append(li);
    }
  }

  async save() {
    const name = this.nameInput.value.trim();
    const aus = this.getPose();
    if (!name) { toast("give the new expression a name"); return; }
    if (!Object.keys(aus).length) { toast("move some AU sliders first: an expression needs at least one AU"); return; }
    const e = await api("/api/expressions", { method: "POST", body: { name, aus } });
    toast(`saved expression “${e.name}” to your library`, "ok", 3000);
    await this.refresh();
  }

  async remove(name) {
    await api(`/api/expressions/${encodeURIComponent(name)}`, { method: "DELETE" });
    await this.refresh();
  }
}

export class LatentPanel {
  constructor(panel, box, labelSelect, onPose) {
    Object.assign(this, { panel, box, labelSelect, onPose });
    this.z = [];
  }

  async init() {
    const info = await api("/api/latent", { quiet: true }).catch(() => ({ available: false }));
    this.info = info;
    if (!info.available) return false;
    this.z = new Array(info.latent_dim).fill(0);
    const go = debounce(() => this.sample(), 60);
    for (let i = 0; i < info.latent_dim; i++) {
      const out = el("output", {}, fmt(0));
      this.box.append(el("div", { class: "au-row" },
        el("div", { class: "au-label" }, el("span", {}, el("b", {}, `z${i + 1}`))),
        el("input", { type: "range", min: -3, max: 3, step: 0.05, value: 0, dataset: { z: i },
          oninput: (e) => { this.z[i] = Number(e.target.value); out.textContent = fmt(this.z[i]); go(); } }),
        out, el("span")));
    }
    if (info.labels && info.labels.length) {
      this.labelSelect.hidden = false;
      for (const l of info.labels) this.labelSelect.append(el("option", { value: l }, l));
      this.labelSelect.addEventListener("change", go);
    }
    this.panel.hidden = false;
    return true;
  }

  async sample() {
    const label = this.labelSelect.hidden ? null : this.labelSelect.value;
    const r = await api("/api/latent/sample", { method: "POST", body: { z: this.z, label } });
    this.onPose(r.aus);
  }
}
