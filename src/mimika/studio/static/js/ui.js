// Small DOM helpers: element builder, toasts, a confirm dialog, debounce, FACS letters.

export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === "class") e.className = v;
    else if (k === "text") e.textContent = v;
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (k === "dataset") Object.assign(e.dataset, v);
    else e.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children.flat()) {
    if (c === null || c === undefined) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

// A toast in the lower right. ms = 0 keeps it until closed; action = {label, run}.
export function toast(message, kind = "error", ms = 8000, action = null) {
  (window.__mimikaToasts ||= []).push(String(message));  // read by the browser tests
  const box = document.getElementById("toasts");
  const t = el("div", { class: `toast ${kind}`, role: kind === "error" ? "alert" : "status" },
    el("span", { class: "msg" }, message));
  const close = () => t.remove();
  if (action) t.append(el("button", { onclick: () => { close(); action.run(); } }, action.label));
  if (!ms || kind === "error") t.append(el("button", { "aria-label": "Close this message", onclick: close }, "✕"));
  box.append(t);
  if (ms) setTimeout(close, ms);
  t.close = close;
  return t;
}

// A modal question; resolves true for OK.
export function ask(text, ok = "OK", cancel = "Cancel") {
  const d = document.getElementById("dialog");
  document.getElementById("dialog-text").textContent = text;
  document.getElementById("dialog-ok").textContent = ok;
  document.getElementById("dialog-cancel").textContent = cancel;
  return new Promise((resolve) => {
    d.addEventListener("close", () => resolve(d.returnValue === "ok"), { once: true });
    d.returnValue = "cancel";
    d.showModal();
    document.getElementById("dialog-ok").focus();
  });
}

export function debounce(fn, ms) {
  let timer = null;
  const f = (...args) => {
    clearTimeout(timer);
    timer = setTimeout(() => { timer = null; fn(...args); }, ms);
  };
  f.pending = () => timer !== null;
  f.flush = (...args) => { if (timer !== null) { clearTimeout(timer); timer = null; fn(...args); } };
  return f;
}

export const fmt = (x, d = 2) => Number(x).toFixed(d);

// FACS intensity letters: A trace … E maximum, at 0.2 … 1.0 (mimika.facs.parse_intensity)
export const LETTERS = "ABCDE";
export function letterOf(v) {
  if (!(v > 0.05)) return "";
  return LETTERS[Math.min(4, Math.max(0, Math.round(v * 5) - 1))];
}

// "0.6", ".6", "60%", "C", "c" → 0.6; null when it is not an intensity.
export function parseIntensity(text) {
  const s = String(text).trim();
  if (s.length === 1 && LETTERS.includes(s.toUpperCase())) return 0.2 * (LETTERS.indexOf(s.toUpperCase()) + 1);
  const pct = s.endsWith("%");
  const v = Number((pct ? s.slice(0, -1) : s).replace(",", "."));
  if (s === "" || !Number.isFinite(v)) return null;
  const x = pct ? v / 100 : v;
  return x >= 0 && x <= 1 ? x : null;
}

// True when a key press belongs to a text field (typing, not a studio shortcut).
export function typing(target) {
  if (!target || !target.tagName) return false;
  if (target.isContentEditable || target.tagName === "TEXTAREA") return true;
  if (target.tagName === "INPUT") return !["range", "checkbox", "radio", "button", "file"].includes(target.type);
  return target.tagName === "SELECT";
}
