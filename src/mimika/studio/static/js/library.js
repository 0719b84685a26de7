// The expression library panel: built-ins and yours, Apply / add to the timeline / delete,
// and Save sliders (asks before replacing an expression of the same name).
import { api, sentence } from "./api.js";
import { el, fmt, toast, ask } from "./ui.js";

// The library's names: lower case, '-' for spaces; letters, digits, '-', '_', one optional '/'.
const EXPR_RE = /^[a-z0-9][a-z0-9_-]*(\/[a-z0-9][a-z0-9_-]*)?$/;
export const exprKey = (name) => name.trim().toLowerCase().replace(/\s+/g, "-");

export class LibraryPanel {
  constructor({ list, filter, nameInput, saveBtn, onApply, onAdd, getPose, onRefresh = () => {} }) {
    Object.assign(this, { list, filter, nameInput, saveBtn, onApply, onAdd, getPose, onRefresh });
    this.items = [];
    filter.addEventListener("input", () => this.render());
    saveBtn.addEventListener("click", () => this.save().catch(() => {}));
    nameInput.addEventListener("keydown", (e) => { if (e.key === "Enter") { e.preventDefault(); this.save().catch(() => {}); } });
    nameInput.addEventListener("input", () => nameInput.removeAttribute("aria-invalid"));
  }

  async refresh() {
    const data = await api("/api/expressions");
    this.items = data.expressions;
    this.render();
    this.onRefresh();
    return this.items;
  }

  names() { return this.items.map((e) => e.name); }
  has(name) { return this.items.some((e) => e.name === name || e.name === `template/${name}`); }

  render() {
    const q = this.filter.value.trim().toLowerCase();
    this.list.innerHTML = "";
    for (const e of this.items) {
      if (q && !e.name.includes(q)) continue;
      const aus = Object.entries(e.aus).map(([c, v]) => `${c.slice(2)}${v < 1 ? "·" + fmt(v, 1) : ""}`).join(" ");
      const li = el("li", { class: e.builtin ? "" : "user", dataset: { name: e.name }, title: e.description || aus },
        el("span", { class: "nm" }, e.name, el("small", {}, aus)),
        el("button", { onclick: () => this.onApply(e), title: "set the sliders to it", "aria-label": `Apply ${e.name}` }, "Apply"),
        el("button", { onclick: () => this.onAdd(e), title: "add it to the Expressions track at the playhead", "aria-label": `+TL: add ${e.name} to the timeline` }, "+TL"),
        e.builtin ? null : el("button", { onclick: () => this.remove(e.name).catch(() => {}), title: "delete it from your library", "aria-label": `Delete ${e.name}` }, "✕"));
      this.list.append(li);
    }
    if (!this.list.children.length) this.list.append(el("li", { class: "muted" }, q ? "no expression matches" : "the library is empty"));
  }

  invalid(msg) {
    this.nameInput.setAttribute("aria-invalid", "true");
    toast(msg);
    this.nameInput.focus();
  }

  async save() {
    const raw = this.nameInput.value;
    const key = exprKey(raw);
    const aus = this.getPose();
    if (!key) return this.invalid("Give the new expression a name first.");
    if (!EXPR_RE.test(key) || key.startsWith("template/")) {
      return this.invalid(`“${raw.trim()}” cannot name an expression: use letters, digits, '-' or '_' (spaces become '-'), for example “my-smile”.`);
    }
    if (!Object.keys(aus).length) { toast("Move some Action Unit sliders first: an expression needs at least one AU."); return; }
    let force = false;
    const existing = this.items.find((e) => e.name === key || e.name === `template/${key}`);
    if (existing) {
      const what = existing.builtin ? `“${existing.name}” is a built-in expression. Save yours as “${key}” in its place?`
        : `There is already an expression called “${key}” in your library. Replace it with the current sliders?`;
      if (!(await ask(what, "Replace", "Keep the old one"))) return;
      force = true;
    }
    let e;
    try {
      e = await api("/api/expressions", { method: "POST", body: { name: key, aus, force }, quiet: true });
    } catch (err) {
      if (err.status === 409) return this.invalid(sentence(err.message));
      toast(err.message);
      return;
    }
    this.nameInput.value = "";
    toast(`Saved “${e.name}” to your library.`, "ok", 3000);
    await this.refresh();
  }

  async remove(name) {
    if (!(await ask(`Delete “${name}” from your library? Triggers that use it will need another expression.`, "Delete"))) return;
    await api(`/api/expressions/${encodeURIComponent(name)}`, { method: "DELETE" });
    toast(`Deleted “${name}”.`, "ok", 2500);
    await this.refresh();
  }
}
