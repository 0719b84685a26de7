"""``mimika gan`` and ``mimika train gan``: outputs and one-line errors (exit 2)."""

import argparse
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

import mimika.cli as cli
from mimika.commands import gan as gan_cmd


@pytest.fixture
def run(monkeypatch, capsys):
    if "gan" not in cli.MODULES:
        monkeypatch.setattr(cli, "MODULES", (*cli.MODULES, "gan"))

    def _run(*argv):
        rc = cli.main(list(argv))
        out, err = capsys.readouterr()
        return rc, out, err

    return _run


def test_sample_prints_aus(run):
    rc, out, err = run("gan", "sample", "--z", "-3,2,0,0,0,0")  # the default controller: 6
    assert rc == 0 and "AU" in out and err == ""
    rc, out4, err = run("gan", "sample", "--model", "seed", "--z", "-3,2,0,0")  # seed's WGAN
    assert rc == 0 and "AU" in out4 and out4 != out


def test_bad_z_length_is_one_line(run):
    rc, _, err = run("gan", "sample", "--z", "-3,2,0")
    assert rc == 2
    assert err.strip().count("\n") == 0
    assert "3 value(s)" in err and "6 latent sliders" in err


def test_bad_z_text(run):
    rc, _, err = run("gan", "sample", "--z", "1,a,0,0")
    assert rc == 2 and "comma-separated numbers" in err


def test_unknown_label_is_one_line(run):
    rc, _, err = run("gan", "sample", "--label", "suprise")
    assert rc == 2 and err.count("\n") == 1
    assert "unknown label 'suprise'" in err and "did you mean 'surprise'" in err


def test_missing_model(run, tmp_path):
    rc, _, err = run("gan", "grid", "--model", str(tmp_path / "nope.pt"), "-o",
                     str(tmp_path / "g.png"))
    assert rc == 2 and "does not exist" in err


def _synthetic_take(path: Path) -> Path:
    from mimika.io.tracks import write_track
    from mimika.tracks import AUTrack

    rng = np.random.default_rng(0)
    t = np.linspace(0, 12, 300)
    vals = np.stack([0.5 + 0.5 * np.sin(t), 0.5 + 0.5 * np.cos(t),
                     np.clip(rng.normal(0.3, 0.1, len(t)), 0, 1)], axis=1)
    return write_track(AUTrack(vals.astype(np.float32), ("AU01", "AU12", "AU27"), 30.0), path,
                       format="arkit")


def test_train_gan_then_invert(tmp_path, run, capsys):
    data = tmp_path / "takes"
    data.mkdir()
    take = _synthetic_take(data / "one.csv")
    p = argparse.ArgumentParser()
    gan_cmd.add_train_gan_arguments(p)
    out = tmp_path / "m.pt"
    args = p.parse_args(["--data", str(data), "--latent", "2", "--n-critic", "2", "--iters", "5",
                         "--encoder-steps", "20", "-o", str(out)])
    assert gan_cmd.train_gan_command(args) == 0
    assert out.is_file() and "wrote" in capsys.readouterr().out
    rc, text, err = run("gan", "invert", str(take), "--frame", "20", "--model", str(out))
    assert rc == 0 and text.startswith("z = ") and "RMSE" in text
    rc, _, err = run("gan", "sample", "--model", str(out), "--z", "0,0,0,0")
    assert rc == 2 and "2 latent sliders" in err


def test_train_controller_then_sample(tmp_path, run, capsys):
    data = tmp_path / "takes"
    data.mkdir()
    _synthetic_take(data / "one.csv")
    out = tmp_path / "c.pt"
    rc, text, err = run("train", "controller", "--data", str(data), "--latent", "2", "--iters",
                        "20", "-o", str(out), "-q")
    assert rc == 0 and out.is_file()
    rc, text, err = run("gan", "sample", "--model", str(out), "--z", "1.5,-1")
    assert rc == 0 and "AU" in text
    rc, _, err = run("train", "controller", "--data", str(data), "--latent", "0", "-o",
                     str(out))
    assert rc == 2 and "--latent 0" in err


def test_train_gan_errors(tmp_path):
    from mimika.errors import MimikaError

    p = argparse.ArgumentParser()
    gan_cmd.add_train_gan_arguments(p)
    with pytest.raises(MimikaError, match=r"\.pt"):
        gan_cmd.train_gan_command(p.parse_args(["-o", str(tmp_path / "x.png")]))
    with pytest.raises(MimikaError, match="not a folder"):
        gan_cmd.train_gan_command(p.parse_args(["--data", str(tmp_path / "no"), "-o",
                                                str(tmp_path / "x.pt")]))
    with pytest.raises(MimikaError, match=r"--classifier .* needs --conditional"):
        gan_cmd.train_gan_command(p.parse_args(["--classifier", "3", "-o",
                                                str(tmp_path / "x.pt")]))


@pytest.mark.skipif(not os.environ.get("MIMIKA_MOTION_DIR"),
                    reason="MIMIKA_MOTION_DIR not set (Live Link Face takes)")
def test_real_data_split_by_take_and_labels():
    from mimika.learn.gan_data import LABELS, load_frames

    fs = load_frames()
    train, test = fs.split()
    assert set(np.unique(test.take)) == {fs.takes.index("apfel")}
    assert fs.takes.index("apfel") not in set(np.unique(train.take))
    assert fs.values.min() >= 0 and fs.values.max() <= 1 and fs.values.shape[1] == 20
    counts = train.label_counts()
    assert set(counts) == set(LABELS) and all(n > 100 for n in counts.values())
