"""Compare the studio's live three.js view with mimika's renderer, side by side.

For each look (plain: ``mimika pose``; news: the newsreader's skin shader and set) and a few
poses, this renders the pose with the server's renderer (``/api/export/png``) and with the
page's three.js view at the same size and framing (``mimikaStudio.viewer.still``), writes
``render | studio | difference ×4`` images and prints the mean absolute difference (0–255,
over the whole picture and over the face) per look.

    PYTHONPATH=src python scripts/studio_look_compare.py -o docs/img
"""

from __future__ import annotations

import argparse
import base64
import io
import socket
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from PIL import Image

POSES = {"neutral": {}, "smile": {"AU06": 0.7, "AU12": 1.0},
         "surprise": {"AU01": 0.8, "AU02": 0.8, "AU05": 0.6, "AU26": 0.7}}


def serve():
    import uvicorn

    from mimika.studio.app import create_app

    d = Path(tempfile.mkdtemp(prefix="mimika-look-"))
    app = create_app(d / "projects", library_path=d / "expressions.json")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    threading.Thread(target=srv.run, daemon=True).start()
    while not srv.started:
        time.sleep(0.05)
    return srv, f"http://127.0.0.1:{port}/"


def decode(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).astype(np.int16)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", type=Path, default=Path("out/look"))
    ap.add_argument("--head", default="builtin")
    ap.add_argument("--size", default="480x360", help="picture size WxH (default 480x360)")
    ap.add_argument("--poses", default=",".join(POSES), help=f"of {', '.join(POSES)}")
    args = ap.parse_args()
    W, H = (int(x) for x in args.size.split("x"))
    poses = {k: POSES[k] for k in args.poses.split(",")}
    args.out.mkdir(parents=True, exist_ok=True)
    from playwright.sync_api import sync_playwright

    srv, url = serve()
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path="/usr/bin/chromium",
                              args=["--no-sandbox", "--disable-gpu"])
        pg = b.new_page(viewport={"width": 1280, "height": 800})
        pg.goto(url)
        pg.wait_for_function("window.mimikaStudio && mimikaStudio.ready", timeout=120_000)
        if args.head != "builtin":
            pg.select_option("#head-select", args.head)
            pg.wait_for_function(f"mimikaStudio.state.head === {args.head!r}", timeout=300_000)
        for look in ("plain", "news"):
            pg.select_option("#look-select", look)
            rows, diffs, face = [], [], []
            for name, aus in poses.items():
                pg.evaluate("(aus) => { mimikaStudio.panel.setPose(aus); "
                            "mimikaStudio.viewer.apply(aus); }", aus)
                shot = pg.evaluate(f"mimikaStudio.viewer.still({W}, {H})")
                studio = decode(base64.b64decode(shot.split(",", 1)[1]))
                r = pg.request.post(url + "api/export/png", data={
                    "aus": aus, "look": look, "width": W, "height": H, "head": args.head})
                render = decode(r.body())
                d = np.abs(render - studio)
                diffs.append(d.mean())
                face.append(d[H // 6: 5 * H // 6, W // 4: 3 * W // 4].mean())
                rows.append(np.concatenate([render, studio, np.clip(d * 4, 0, 255)], 1))
                print(f"{look:6s} {name:9s} mean |render − studio| = {diffs[-1]:5.1f} "
                      f"(face {face[-1]:5.1f}) of 255")
            sheet = np.concatenate(rows, 0).astype(np.uint8)
            path = args.out / f"studio-look-{look}-{args.head}.png"
            Image.fromarray(sheet).save(path)
            print(f"{look}: mean {np.mean(diffs):.1f}, face {np.mean(face):.1f} → {path}")
        b.close()
    srv.should_exit = True


if __name__ == "__main__":
    main()
