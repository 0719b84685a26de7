"""Studio exports under a long one (issue 20): the latency of a short CSV export alone and
while a long export runs (a 59 s MP4, or a 3 000 s CSV without headless OpenGL). Exports
used to run one at a time, so a short one waited for the long one (0.2 s → 5.6 s); now they
run in two lanes. Target: the short export no slower than 3× alone.

Run: ``.venv/bin/python bench/bench_studio_exports.py``
"""

import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent / "tests"))
import httpx

from _common import report
from conftest import serve_app
from mimika.studio.app import create_app


def project(events) -> dict:
    return {"format": "mimika-project", "version": 1, "settings": {"head": "builtin"},
            "timeline": {"channels": [{"name": "face", "events": events}]}}


SHORT = {"project": project([{"kind": "expression", "start": 0.2, "duration": 1.5,
                              "name": "happiness"}]), "fps": 30, "speech": False}


def short_latency(c: httpx.Client, n: int = 5) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        c.post("/api/export/csv", json=SHORT).raise_for_status()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    d = Path(tempfile.mkdtemp(prefix="mimika-bench-"))
    app = create_app(d / "projects", library_path=d / "expressions.json")
    mp4 = app.state.studio.mp4_unavailable() is None
    if mp4:
        from mimika.render.context import egl_available

        mp4 = egl_available()
    with serve_app(app) as port, httpx.Client(base_url=f"http://127.0.0.1:{port}",
                                              timeout=600) as c:
        short_latency(c, 2)  # warm up
        alone = short_latency(c)
        if mp4:
            kind, body = "mp4", {"project": project([{"kind": "aus", "start": 0.0,
                                                      "duration": 59.0,
                                                      "aus": [["AU12", 1.0]]}]),
                                 "fps": 30, "speech": False}
        else:
            kind, body = "csv", {"project": project([{"kind": "aus", "start": 0.0,
                                                      "duration": 3000.0,
                                                      "aus": [["AU12", 1.0]]}]),
                                 "fps": 60, "speech": False}
        th = threading.Thread(target=lambda: c.post(f"/api/export/{kind}?job=long",
                                                    json=body))
        th.start()
        while not c.get("/api/export/jobs").json()["jobs"]:
            time.sleep(0.05)
        during = short_latency(c)
        still = bool(c.get("/api/export/jobs").json()["jobs"])
        c.delete("/api/export/jobs/long")
        th.join()
    print(f"long export: {kind}; still running after the short ones: {still}")
    report("short CSV export alone (median of 5)", alone * 1000, "ms")
    report(f"short CSV export during a long {kind} export", during * 1000, "ms")
    report("slow-down under the long export", during / alone, "x (target ≤ 3)")


if __name__ == "__main__":
    main()
