// The WGAN latent sliders (tab "Latent"): one slider per latent dimension, when mimika.learn
// and a model load on the server; otherwise the tab says why.
import { api } from "./api.js";
import { el, fmt, debounce } from "./ui.js";

export class LatentPanel {
  constructor({ status, box, labelRow, labelSelect, onPose, onCommit }) {
    Object.assign(this, { status, box, labelRow, labelSelect, onPose, onCommit });
    this.z = [];
    this.state = "loading";
  }

  async init() {
    const info = await api("/api/latent", { quiet: true }).catch(() => ({ available: false, reason: "the server did not answer" }));
    this.info = info;
    if (!info.available) {
      this.status.textContent = `Latent sliders are not available here: ${String(info.reason || "no model").replace(/^latent sliders unavailable: /, "")}.`;
      this.state = "unavailable";
      return false;
    }
    this.z = new Array(info.latent_dim).fill(0);
    const go = debounce(() => { this.pending = this.sample().catch(() => {}); }, 60);
    const commit = () => { go.flush(); (this.pending || Promise.resolve()).then(() => this.onCommit()); };
    this.status.textContent = `${info.latent_dim} latent dimensions of the face controller (−3 … 3).`;
    for (let i = 0; i < info.latent_dim; i++) {
      const val = el("output", {}, fmt(0));
      const inp = el("input", { type: "range", min: -3, max: 3, step: 0.05, value: 0, dataset: { z: i },
        "aria-label": `Latent dimension ${i + 1}`, "aria-valuetext": fmt(0),
        oninput: (e) => { this.z[i] = Number(e.target.value); val.textContent = fmt(this.z[i]); e.target.setAttribute("aria-valuetext", fmt(this.z[i])); go(); },
        onchange: commit });
      this.box.append(el("div", { class: "au-row" },
        el("div", { class: "au-label" }, el("span", {}, el("b", {}, `z${i + 1}`))), el("span"), inp, val));
    }
    if (info.labels && info.labels.length) {
      this.labelRow.hidden = false;
      for (const l of info.labels) this.labelSelect.append(el("option", { value: l }, l));
      this.labelSelect.addEventListener("change", () => { go(); commit(); });
    }
    this.state = "ready";
    return true;
  }

  async sample() {
    const label = this.labelRow.hidden ? null : this.labelSelect.value;
    const r = await api("/api/latent/sample", { method: "POST", body: { z: this.z, label } });
    this.onPose(r.aus);
  }
}
