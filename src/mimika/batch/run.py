"""Run a batch plan on Dask distributed: resumable, streaming, with an atomic manifest.

Pending items are grouped into tasks (same head and identity, a few items each) and submitted
to a Dask cluster — a :class:`distributed.LocalCluster` of worker *processes* by default (each
with its own headless GL context), or an existing scheduler. Results stream back with
``as_completed``; the client writes every image atomically and rewrites ``labels.csv`` and
``manifest.json`` (atomically) every few seconds, so an interrupted run leaves a consistent
record of what finished. A rerun skips every item whose file exists and whose manifest entry is
complete and unchanged.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import logging
import math
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mimika.batch.plan import Item, Plan, make_plan
from mimika.batch.spec import BatchSpec
from mimika.errors import DataError, ParameterError
from mimika.io.atomic import atomic_write
from mimika.limits import loads_json

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"
LABELS = "labels.csv"
FORMAT = "mimika-batch-manifest"
VERSION = 1
LABEL_FIELDS = ("item", "file", "clip", "head", "identity", "view", "kind", "content",
                "intensity", "requested")

Progress = Callable[[int, int], None]


@dataclass
class BatchReport:
    """What a run did. ``rendered`` counts items finished by this run, ``skipped`` those
    already finished before it; ``pending`` is what is left (interrupted or failed runs)."""

    out: Path
    total: int
    skipped: int = 0
    rendered: int = 0
    failed: int = 0
    pending: int = 0
    workers: int = 0
    tasks: int = 0
    wall_s: float = 0.0
    interrupted: bool = False
    dry_run: bool = False
    spec_hash: str = ""
    errors: list[str] = field(default_factory=list)
    todo: list[Item] = field(default_factory=list)

    @property
    def images_per_s(self) -> float:
        return self.rendered / self.wall_s if self.wall_s > 0 else 0.0


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _num(v: float) -> str:
    return f"{v:.6f}".rstrip("0").rstrip(".") if v else "0"


def _identity_text(identity: Any) -> str:
    if identity is None:
        return ""
    if isinstance(identity, int):
        return str(identity)
    return ";".join(_num(w) for w in identity)


def labels_csv(plan: Plan, done: set[str]) -> str:
    """``labels.csv`` text: one row per finished item, in plan order.

    Columns: item, file, clip, head, identity, view, kind, content, intensity, requested
    (``AU01=0.5 AU02=0.5``), then one column per AU code with the value after the AU Blender,
    then ``rules`` (the Blender rules that fired, space-separated).
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*LABEL_FIELDS, *plan.au_columns, "rules"])
    for it in plan.items:
        if it.id not in done:
            continue
        w.writerow([it.id, it.file, it.clip or "", it.head, _identity_text(it.identity), it.view,
                    it.kind, it.content, "" if it.intensity is None else _num(it.intensity),
                    " ".join(f"{c}={_num(v)}" for c, v in it.requested.items()),
                    *(_num(it.aus.get(c, 0.0)) for c in plan.au_columns), " ".join(it.rules)])
    return buf.getvalue()


def read_manifest(out: Path) -> dict[str, Any] | None:
    """The manifest in ``out`` (None if there is none). Raises :class:`DataError` if it is not
    a mimika batch manifest."""
    p = out / MANIFEST
    if not p.exists():
        return None
    try:
        data = loads_json(p.read_bytes(), str(p))
    except (OSError, DataError) as e:
        raise DataError(f"cannot read {p}: {e}; delete it to start over (finished images are "
                        "then rendered again)") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise DataError(f"{p} is not a mimika batch manifest; write the batch to another folder")
    return data


def _finished(out: Path, plan: Plan, old: dict[str, Any] | None) -> dict[str, dict]:
    """Entries of the old manifest that still count: status done, same render key, files
    present and non-empty."""
    if not old:
        return {}
    entries = {e.get("id"): e for e in old.get("items", []) if isinstance(e, dict)}
    keep: dict[str, dict] = {}
    for it in plan.items:
        e = entries.get(it.id)
        if not e or e.get("status") != "done" or e.get("key") != it.key:
            continue
        files = [it.file] + ([it.clip] if it.clip else [])
        if all((out / f).is_file() and (out / f).stat().st_size > 0 for f in files):
            keep[it.id] = e
    stale = len(set(entries) - {it.id for it in plan.items})
    if stale:
        log.info("%d item(s) of an earlier spec are not in this plan; their files are left alone",
                 stale)
    return keep


class _Record:
    """The run's state: entries per item, written as labels.csv + manifest.json atomically."""

    def __init__(self, out: Path, plan: Plan, entries: dict[str, dict], runs: list[dict]):
        self.out, self.plan = out, plan
        self.entries = entries
        self.runs = runs
        self.last_flush = 0.0
        self.flush_cost = 0.0

    def done_ids(self) -> set[str]:
        return {i for i, e in self.entries.items() if e.get("status") == "done"}

    def counts(self) -> dict[str, int]:
        st = [self.entries.get(it.id, {}).get("status", "pending") for it in self.plan.items]
        return {"items": len(st), "done": st.count("done"), "failed": st.count("failed"),
                "pending": st.count("pending")}

    def manifest(self) -> dict[str, Any]:
        from mimika import __version__

        spec = self.plan.spec
        items = []
        for it in self.plan.items:
            e = self.entries.get(it.id) or {"status": "pending"}
            items.append({"id": it.id, "file": it.file, "clip": it.clip, "key": it.key, **{
                k: v for k, v in e.items() if k not in ("id", "file", "clip", "key")}})
        return {"format": FORMAT, "version": VERSION, "mimika": __version__,
                "spec": {"source": spec.source, "hash": spec.hash, "name": spec.name,
                         "normalised": spec.to_dict()},
                "clip_format": self.plan.clip_format, "au_columns": list(self.plan.au_columns),
                "counts": self.counts(), "updated": _now(), "timing": {"runs": self.runs},
                "items": items}

    def flush(self) -> None:
        t0 = time.perf_counter()
        atomic_write(self.out / LABELS, labels_csv(self.plan, self.done_ids()))
        atomic_write(self.out / MANIFEST, json.dumps(self.manifest(), indent=1) + "\n")
        self.last_flush = time.monotonic()
        self.flush_cost = time.perf_counter() - t0

    def maybe_flush(self, interval: float) -> None:
        # big manifests are rewritten less often: never spend more than ~10 % on bookkeeping
        if time.monotonic() - self.last_flush >= max(interval, 10 * self.flush_cost):
            self.flush()


def _tasks(items: Sequence[Item], size: int) -> list[list[Item]]:
    """Consecutive items of the same head and identity, ``size`` at most per task."""
    tasks: list[list[Item]] = []
    for it in items:
        if tasks and len(tasks[-1]) < size and (tasks[-1][0].head, tasks[-1][0].identity) == (
                it.head, it.identity):
            tasks[-1].append(it)
        else:
            tasks.append([it])
    return tasks


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _connect(workers: int | None, scheduler: str | None, n_items: int) -> tuple[Any, Any, int]:
    """(client, own cluster or None, number of workers); a local cluster gets at most one
    worker per item."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as e:
        raise ParameterError(f"batch runs need Dask ({e}); install it with: "
                             "pip install 'mimika[batch]'") from None
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as e:
            raise ParameterError(f"cannot connect to the Dask scheduler {scheduler!r}: {e}") \
                from None
        n = len(client.scheduler_info().get("workers", {}))
        log.info("connected to %s (%d workers)", scheduler, n)
        return client, None, n
    n = int(workers or max(1, min(os.cpu_count() or 1, 8)))
    if n < 1:
        raise ParameterError(f"workers={n} must be ≥ 1")
    n = min(n, max(1, n_items))
    # llvmpipe renders with as many threads as cores; share the cores among the workers
    threads = str(max(1, (os.cpu_count() or 1) // n))
    env = {"LP_NUM_THREADS": os.environ.get("LP_NUM_THREADS", threads),
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    # ":0": a free port for the HTTP routes (no clash with other clusters on 8787).
    # worker processes ignore Ctrl-C (they inherit SIG_IGN): only this process handles it,
    # records what finished and shuts the cluster down
    with _sigint_ignored():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.CRITICAL, env=env)
    client = Client(cluster)
    log.info("started a local Dask cluster: %d worker processes", n)
    return client, cluster, n


def run_batch(
    spec: BatchSpec | Plan,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    progress: Progress | None = None,
    dry_run: bool = False,
    chunk: int | None = None,
    flush_interval: float = 2.0,
    stop_after: int | None = None,
) -> BatchReport:
    """Render every unfinished item of ``spec`` into ``out``.

    Parameters
    ----------
    spec : a validated spec (or its plan)
    out : output folder (``images/``, ``clips/``, ``labels.csv``, ``manifest.json``)
    workers : worker processes of the local cluster (default: the CPU count, at most 8)
    scheduler : address of an existing Dask scheduler (``tcp://host:8786``) instead
    client : an existing ``distributed.Client`` to use (neither started nor closed here)
    progress : ``progress(done, total)`` after every finished task
    dry_run : plan and check what is finished, render nothing, write nothing
    chunk : items per task (default: about four tasks per worker, 1–16 items each)
    flush_interval : seconds between manifest rewrites
    stop_after : stop as if interrupted once this many items finished (for tests)

    Returns
    -------
    BatchReport. Items that failed are recorded in the manifest and retried by the next run.
    """
    plan = spec if isinstance(spec, Plan) else make_plan(spec)
    out = Path(out)
    old = read_manifest(out)
    finished = _finished(out, plan, old)
    todo = [it for it in plan.items if it.id not in finished]
    report = BatchReport(out=out, total=len(plan), skipped=len(finished), pending=len(todo),
                         dry_run=dry_run, spec_hash=plan.spec.hash, todo=todo)
    if old and old.get("spec", {}).get("hash") != plan.spec.hash:
        log.info("the spec changed since the last run; %d finished item(s) still match",
                 len(finished))
    if dry_run:
        return report
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise DataError(f"cannot create output folder {str(out)!r}: {e.strerror or e}") from None
    runs = list((old or {}).get("timing", {}).get("runs", []))
    run_info: dict[str, Any] = {"started": _now(), "skipped": len(finished)}
    runs.append(run_info)
    record = _Record(out, plan, dict(finished), runs)
    done_total = len(finished)
    if progress:
        progress(done_total, len(plan))
    t0 = time.perf_counter()
    own_client = cluster = None
    by_future: dict[Any, list[Item]] = {}
    try:
        record.flush()
        if todo:
            if client is None:
                own_client, cluster, n = _connect(workers, scheduler, len(todo))
                client = own_client
            else:
                n = len(client.scheduler_info().get("workers", {}))
            report.workers = n
            size = chunk or max(1, min(16, math.ceil(len(todo) / (max(n, 1) * 4))))
            tasks = _tasks(todo, size)
            report.tasks = len(tasks)
            settings = plan.settings()
            from dask.distributed import as_completed

            from mimika.batch.worker import render_items

            by_future = {client.submit(render_items, [it.payload() for it in t], settings,
                                       pure=False): t for t in tasks}
            log.info("%d items in %d tasks on %d workers", len(todo), len(tasks), n)
            for fut in as_completed(list(by_future)):
                task = by_future.pop(fut)
                results = _results(fut, task)
                fut.release()  # the images are on disk now: let the cluster forget them
                for it, res in zip(task, results, strict=True):
                    if _store(out, it, res, record):
                        report.rendered += 1
                    else:
                        report.failed += 1
                        if len(report.errors) < 5:
                            report.errors.append(f"{it.id}: {res.get('error')}")
                done_total += len(results)
                if progress:
                    progress(done_total, len(plan))
                record.maybe_flush(flush_interval)
                if stop_after is not None and report.rendered >= stop_after:
                    report.interrupted = True
                    break
    except KeyboardInterrupt:
        report.interrupted = True
        raise
    finally:
        if by_future:
            client.cancel(list(by_future))
        report.wall_s = time.perf_counter() - t0
        counts = record.counts()
        report.pending = counts["pending"]
        run_info.update({"finished": _now(), "wall_s": round(report.wall_s, 3),
                         "rendered": report.rendered, "failed": report.failed,
                         "workers": report.workers, "tasks": report.tasks,
                         "images_per_s": round(report.images_per_s, 3),
                         "interrupted": report.interrupted})
        record.flush()
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()
    log.info("batch %s: %d rendered, %d skipped, %d failed, %d pending in %.1f s", out,
             report.rendered, report.skipped, report.failed, report.pending, report.wall_s)
    return report


def _results(fut: Any, items: list[Item]) -> list[dict[str, Any]]:
    """A task's results, or one failure per item if the whole task failed."""
    try:
        res = fut.result()
    except Exception as e:
        log.warning("a task of %d items failed: %s", len(items), e)
        return [{"id": it.id, "ok": False, "error": f"{type(e).__name__}: {e}"} for it in items]
    return list(res)


def _store(out: Path, it: Item, res: dict[str, Any], record: _Record) -> bool:
    """Write an item's files (atomically) and record it; False if it failed."""
    entry: dict[str, Any] = {"seconds": res.get("seconds"), "worker": res.get("worker"),
                             "finished": _now()}
    if res.get("ok"):
        try:
            atomic_write(out / it.file, res["png"])
            if it.clip and res.get("clip") is not None:
                atomic_write(out / it.clip, res["clip"])
        except OSError as e:
            res = {"ok": False, "error": f"cannot write {it.file}: {e.strerror or e}"}
    if res.get("ok"):
        record.entries[it.id] = {"status": "done", **entry}
        return True
    record.entries[it.id] = {"status": "failed", "error": res.get("error"), **entry}
    return False
