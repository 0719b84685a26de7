"""The GRID recordings in ``$MIMIKA_SPEECH_DIR`` (default ``../shared/speech/grid-s1-dev``):
utterances, their transcripts, a fixed train/test split by utterance and the
transcript-aligned reference of each (cached in a pickle, since aligning all 200 takes
minutes).

GRID audiovisual sentence corpus, Cooke, Barker, Cunningham & Shao (2006), CC BY 4.0.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path

import numpy as np

_GRID = Path("shared", "speech", "grid-s1-dev")
DEFAULT_DIR = next((p / _GRID for p in Path(__file__).resolve().parents if (p / _GRID).is_dir()),
                   _GRID)


def grid_dir() -> Path:
    d = Path(os.environ.get("MIMIKA_SPEECH_DIR", str(DEFAULT_DIR)))
    if not (d / "wav").is_dir():
        raise SystemExit(f"no GRID data in {d} (set MIMIKA_SPEECH_DIR)")
    return d


def ids(d: Path) -> list[str]:
    return sorted(p.stem for p in (d / "wav").glob("*.wav"))


def is_test(uid: str) -> bool:
    """The test split: a fifth of the utterances, by a hash of the name (the names spell
    the sentence, so sorted order would group the commands)."""
    return int(hashlib.sha1(uid.encode()).hexdigest(), 16) % 5 == 0


def words(d: Path, uid: str) -> list[str]:
    return [ln.split()[2] for ln in (d / "align" / f"{uid}.align").read_text().splitlines()
            if ln.split()[2] not in ("sil", "sp")]


def load(d: Path, uid: str) -> tuple[np.ndarray, int]:
    from mimika.speech.audio import read_wav

    return read_wav(d / "wav" / f"{uid}.wav")


def references(d: Path, uids: list[str], cache: Path | None = None):
    """``{id: Utterance}`` aligned to the transcript (``mimika align`` with it)."""
    from mimika.speech import Phone, Utterance
    from mimika.speech.alignment import align

    got: dict[str, list[tuple]] = {}
    if cache is not None and cache.is_file():
        got = pickle.loads(cache.read_bytes())
    for uid in uids:
        if uid not in got:
            a, sr = load(d, uid)
            u = align(a, sr=sr, transcript=" ".join(words(d, uid)))
            got[uid] = [(p.symbol, p.start, p.end, p.stress) for p in u.phonemes]
    if cache is not None:
        cache.write_bytes(pickle.dumps(got))
    return {uid: Utterance(np.zeros(0, np.float32), 16000, [Phone(*p) for p in got[uid]],
                           lang="en") for uid in uids}
