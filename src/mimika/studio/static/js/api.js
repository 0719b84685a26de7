// fetch wrapper: JSON in/out; errors become ApiError with a message for people (the server's
// own words for 4xx, a plain sentence for server faults and lost connections).
import { toast } from "./ui.js";

export class ApiError extends Error {
  constructor(message, status, body) { super(message); this.status = status; this.body = body; }
}

const SERVER_FAULT = "Something went wrong inside the studio server (its log has the details). " +
  "Your work in this page is unchanged; try again, or save the project.";
const NO_SERVER = "The studio server is not answering. Is “mimika studio” still running? " +
  "Your work in this page is unchanged.";

export async function api(path, { method = "GET", body, raw = false, quiet = false, signal } = {}) {
  const opts = { method, headers: {}, signal };
  if (body instanceof Uint8Array) {
    opts.headers["Content-Type"] = "application/octet-stream";
    opts.body = body;
  } else if (body !== undefined) {
    opts.headers["Content-Type"] = "application/json";
    opts.body = JSON.stringify(body);
  }
  let res;
  try {
    res = await fetch(path, opts);
  } catch (e) {
    if (e.name === "AbortError") throw new ApiError("cancelled", -1, null);
    const err = new ApiError(NO_SERVER, 0, null);
    if (!quiet) toast(err.message);
    throw err;
  }
  if (!res.ok) {
    let data = null;
    try { data = await res.json(); } catch { /* not JSON */ }
    let msg = res.status >= 500 || !(data && data.error) ? SERVER_FAULT : data.error;
    if (res.status === 501 && data && data.error) msg = data.error;
    const err = new ApiError(sentence(msg), res.status, data);
    if (!quiet) toast(err.message);
    throw err;
  }
  return raw ? res : res.json();
}

// First letter up, full stop at the end.
export function sentence(msg) {
  const s = String(msg).trim();
  if (!s) return s;
  const t = s[0].toUpperCase() + s.slice(1);
  return /[.!?…:]$/.test(t) ? t : `${t}.`;
}

// Save a blob under ``filename`` (the browser's download).
export function saveBlob(blob, filename) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  return blob.size;
}

export async function download(path, body, filename, { signal, quiet = false } = {}) {
  const res = await api(path, { method: "POST", body, raw: true, signal, quiet });
  return saveBlob(await res.blob(), filename);
}
