// fetch wrapper: JSON in/out; errors become Error(message from {"error": …}) and a toast.
import { toast } from "./ui.js";

export class ApiError extends Error {
  constructor(message, status, body) { super(message); this.status = status; this.body = body; }
}

export async function api(path, { method = "GET", body, raw = false, quiet = false } = {}) {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = "application/json";
    opts.body = JSON.stringify(body);
  }
  let res;
  try {
    res = await fetch(path, opts);
  } catch (e) {
    const err = new ApiError(`cannot reach the studio server (${e.message})`, 0, null);
    if (!quiet) toast(err.message);
    throw err;
  }
  if (!res.ok) {
    let msg = `${res.status} ${res.statusText}`;
    let data = null;
    try { data = await res.json(); if (data && data.error) msg = data.error; } catch { /* not JSON */ }
    const err = new ApiError(msg, res.status, data);
    if (!quiet) toast(msg);
    throw err;
  }
  return raw ? res : res.json();
}

export async function download(path, body, filename) {
  const res = await api(path, { method: "POST", body, raw: true });
  const blob = await res.blob();
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  return blob.size;
}
