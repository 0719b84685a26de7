// The Action Unit sliders in the FACS manual's groups: a slider and a typed value (0–1, 60 %
// or a FACS letter A–E) per AU, L/R split for sided AUs. onChange(pose) on every move,
// onCommit() when an edit is finished (for undo).
import { el, fmt, letterOf, parseIntensity, toast } from "./ui.js";

const GROUP_TITLE = { "upper face": "Upper face", "lower face linear": "Lower face — linear",
  "lower face orbital": "Lower face — orbital", head: "Head", eyes: "Eyes" };
const SIDE = { L: "left", R: "right" };

const shown = (v) => { const l = letterOf(v); return l ? `${fmt(v)} ${l}` : fmt(v); };
const valueText = (v) => { const l = letterOf(v); return l ? `${fmt(v)}, FACS ${l}` : fmt(v); };

export class AUPanel {
  constructor(root, groups, { onChange, onCommit }) {
    Object.assign(this, { root, onChange, onCommit });
    this.values = {};        // code → value (codes incl. L/R when split)
    this.split = new Set();  // bilateral codes shown as L/R
    this.build(groups);
  }

  // (Re)build the rows for a head's AU groups; values of AUs it lacks are dropped.
  build(groups) {
    this.rows = {};
    this.root.innerHTML = "";
    for (const g of groups) {
      const det = el("details", { class: "au-group", open: true, dataset: { group: g.name } },
        el("summary", {}, GROUP_TITLE[g.name] || g.name));
      for (const au of g.aus) {
        const row = el("div", { class: "au-row", dataset: { au: au.code }, role: "group", "aria-label": `${au.code} ${au.name}` });
        det.append(row);
        this.rows[au.code] = { row, au };
      }
      this.root.append(det);
    }
    for (const c of Object.keys(this.values)) if (!this.rows[c.slice(0, 4)]) delete this.values[c];
    for (const c of [...this.split]) if (!this.rows[c] || !this.rows[c].au.sided) this.split.delete(c);
    for (const code of Object.keys(this.rows)) this.renderRow(code);
  }

  slider(code, au, side) {
    const v = this.values[code] || 0;
    const name = `${au.code} ${au.name}${side ? `, ${SIDE[side]}` : ""}`;
    const val = el("input", { class: "val", value: shown(v), "aria-label": `${name}: value or FACS letter`,
      title: "type 0–1, 60% or a FACS letter A–E", spellcheck: "false", autocomplete: "off", dataset: { code } });
    const inp = el("input", { type: "range", min: 0, max: 1, step: 0.01, value: v, "aria-label": name,
      "aria-valuetext": valueText(v), dataset: { code } });
    const show = (x) => { val.value = shown(x); inp.setAttribute("aria-valuetext", valueText(x)); };
    inp.addEventListener("input", () => { this.set(code, Number(inp.value), false); show(Number(inp.value)); });
    inp.addEventListener("change", () => this.onCommit());
    inp.addEventListener("keydown", (e) => {  // A–E on a slider sets that FACS intensity
      const k = e.key.toUpperCase();
      if (e.ctrlKey || e.metaKey || e.altKey || k.length !== 1 || !"ABCDE".includes(k)) return;
      e.preventDefault();
      const x = parseIntensity(k);
      inp.value = x; show(x);
      this.set(code, x, false);
      this.onCommit();
    });
    val.addEventListener("focus", () => val.select());
    val.addEventListener("keydown", (e) => { if (e.key === "Enter") { e.preventDefault(); val.blur(); } });
    val.addEventListener("change", () => {
      const x = parseIntensity(val.value.replace(/^(\d*[.,]?\d+)\s*[A-Ea-e]$/, "$1"));
      if (x === null) {
        val.setAttribute("aria-invalid", "true");
        toast(`${code}: “${val.value}” is not an intensity. Type a value from 0 to 1, a percentage such as 60%, or a FACS letter A–E.`);
        return;
      }
      val.removeAttribute("aria-invalid");
      inp.value = x; show(x);
      this.set(code, x, false);
      this.onCommit();
    });
    return [el("span", { class: "sub-label", "aria-hidden": "true" }, side || ""), inp, val];
  }

  renderRow(code) {
    const { row, au } = this.rows[code];
    row.innerHTML = "";
    const split = this.split.has(code);
    const btn = au.sided ? el("button", { class: "side small", "aria-pressed": String(split),
      title: "left and right separately", "aria-label": `${code} L/R (left and right separately)`,
      onclick: () => { this.toggleSide(code); this.onCommit(); } }, "L/R") : null;
    row.append(el("div", { class: "au-label" },
      el("span", {}, el("b", {}, code), el("span", { class: "name" }, au.name)), btn));
    if (split) row.append(...this.slider(code + "L", au, "L"), ...this.slider(code + "R", au, "R"));
    else row.append(...this.slider(code, au, ""));
    this.markActive(code);
  }

  markActive(base) {
    const r = this.rows[base];
    if (r) r.row.classList.toggle("active", Object.keys(this.values).some((c) => c.startsWith(base)));
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
    if (redraw && this.rows[base]) this.renderRow(base); else this.markActive(base);
    this.onChange(this.pose());
  }

  // The whole pose (an expression, a latent sample); splits sides where a code needs it.
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
  state() { return { values: this.pose(), split: [...this.split].sort() }; }
  setState(s) {
    this.values = { ...s.values };
    this.split = new Set(s.split);
    for (const code of Object.keys(this.rows)) this.renderRow(code);
    this.onChange(this.pose());
  }
}
