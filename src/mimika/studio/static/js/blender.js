// The AU Blender tab: what the rules changed for the current pose, and one switch per rule
// with its plain-language explanation.
import { api } from "./api.js";
import { el, fmt } from "./ui.js";

export class BlenderPanel {
  constructor({ list, filter, trace, onChange }) {
    Object.assign(this, { list, filter, trace, onChange });
    this.rules = [];
    this.off = new Set();
    this.fired = new Set();
    filter.addEventListener("input", () => this.render());
  }

  async load() {
    this.rules = (await api("/api/blend/rules")).rules;
    this.byRule = Object.fromEntries(this.rules.map((r) => [r.rule, r]));
    this.render();
  }

  disabled() { return [...this.off].sort(); }
  setDisabled(list) { this.off = new Set(list || []); this.render(); }

  render() {
    const q = this.filter.value.trim().toLowerCase().replace(/^au0*/, "");
    this.list.innerHTML = "";
    for (const r of this.rules) {
      if (q && !(r.rule.toLowerCase().includes(q) || r.title.toLowerCase().includes(q) || r.text.toLowerCase().includes(q))) continue;
      const id = `rule-${r.rule.replace(/[^0-9A-Za-z]/g, "_")}`;
      const box = el("input", { type: "checkbox", id, checked: !this.off.has(r.rule), "aria-describedby": `${id}-why`,
        onchange: (e) => { if (e.target.checked) this.off.delete(r.rule); else this.off.add(r.rule); this.onChange(this.disabled()); } });
      this.list.append(el("li", { class: this.fired.has(r.rule) ? "fired" : "", dataset: { rule: r.rule } },
        el("label", { for: id, title: r.text }, box, el("code", {}, r.rule), el("span", {}, r.title)),
        el("details", {}, el("summary", {}, "why"), el("p", { id: `${id}-why` }, r.text))));
    }
    if (!this.list.children.length) this.list.append(el("li", { class: "muted" }, "no rule matches"));
  }

  // The blended result of a pose: list the changes, mark the rules that fired.
  showTrace(result, pose) {
    const list = this.trace;
    list.innerHTML = "";
    this.fired = new Set(result ? result.trace.map((t) => t.rule) : []);
    for (const li of this.list.querySelectorAll("li[data-rule]")) li.classList.toggle("fired", this.fired.has(li.dataset.rule));
    if (!Object.keys(pose).length) { list.append(el("li", { class: "muted" }, "all AUs at 0")); return; }
    if (!result) { list.append(el("li", { class: "muted" }, "the AU Blender is off")); return; }
    if (!result.trace.length) { list.append(el("li", { class: "muted" }, "no rule changed anything")); return; }
    for (const t of result.trace) {
      const changes = Object.entries(t.outputs).map(([c, v]) => `${c} ${fmt(t.inputs[c] ?? pose[c] ?? 0)}→${fmt(v)}`).join(", ");
      const r = this.byRule && this.byRule[t.rule];
      list.append(el("li", { title: r ? r.text : "" }, el("code", {}, t.rule), " ", changes, r ? el("span", { class: "muted" }, ` — ${r.title}`) : null));
    }
  }
}
