// Keyboard: the studio's shortcuts (wherever focus is, except while typing), the side panel's
// tabs (arrow keys between tabs) and the drop-down menus (Escape and outside clicks close them).
import { typing } from "./ui.js";

// Elements where Space already means "press" or "toggle".
const SPACE_OWNERS = "button, summary, a, select, [role=button], [role=tab], [role=slider], input[type=checkbox], input[type=radio], input[type=file]";

export function setupKeys({ save, undo, redo, remove, togglePlay, hasSelection }) {
  document.addEventListener("keydown", (e) => {
    const t = e.target;
    const mod = e.ctrlKey || e.metaKey;
    const k = e.key.toLowerCase();
    if (mod && k === "s") { e.preventDefault(); save(); return; }
    if (mod && !e.altKey && (k === "z" || k === "y")) {
      if (typing(t)) return;  // the text field's own undo
      e.preventDefault();
      if (k === "y" || e.shiftKey) redo(); else undo();
      return;
    }
    if (mod || e.altKey) return;
    if (e.key === "Delete" && !typing(t) && hasSelection()) { e.preventDefault(); remove(); return; }
    if (e.key === " " && !typing(t) && !(t.closest && t.closest(SPACE_OWNERS))) {
      e.preventDefault();
      togglePlay();
    }
  });
}

export function setupTabs(list) {
  const tabs = [...list.querySelectorAll("[role=tab]")];
  const show = (tab, focus = false) => {
    for (const t of tabs) {
      const on = t === tab;
      t.setAttribute("aria-selected", String(on));
      t.tabIndex = on ? 0 : -1;
      document.getElementById(t.getAttribute("aria-controls")).hidden = !on;
    }
    if (focus) tab.focus();
  };
  for (const t of tabs) {
    t.addEventListener("click", () => show(t));
    t.addEventListener("keydown", (e) => {
      const i = tabs.indexOf(t);
      const j = { ArrowRight: i + 1, ArrowLeft: i - 1, Home: 0, End: tabs.length - 1 }[e.key];
      if (j === undefined) return;
      e.preventDefault();
      show(tabs[(j + tabs.length) % tabs.length], true);
    });
  }
}

export function setupMenus() {
  const menus = [...document.querySelectorAll("details.menu")];
  document.addEventListener("pointerdown", (e) => {
    for (const m of menus) if (m.open && !m.contains(e.target)) m.open = false;
  });
  for (const m of menus) {
    const body = m.querySelector(".menu-body");
    m.addEventListener("toggle", () => {  // keep the open menu inside the window
      if (!m.open) return;
      body.style.left = "0px";
      const r = body.getBoundingClientRect(), pad = 8;
      let dx = 0;
      if (r.right > window.innerWidth - pad) dx = window.innerWidth - pad - r.right;
      if (r.left + dx < pad) dx = pad - r.left;
      body.style.left = `${dx}px`;
    });
    m.addEventListener("keydown", (e) => {
      if (e.key === "Escape" && m.open) { m.open = false; m.querySelector("summary").focus(); }
    });
    // a menu item that runs an action closes the menu (checkboxes keep it open)
    for (const b of m.querySelectorAll(".menu-body > button")) b.addEventListener("click", () => { m.open = false; });
  }
}
