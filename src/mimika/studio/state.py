"""Server-side state of one studio: the head (rig + GLB), the expression library, a speech
cache, the optional WGAN controller and feature flags. Thread-safe; heavy parts load lazily."""

from __future__ import annotations

import hashlib
import logging
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mimika import limits
from mimika.errors import DataError, MimikaError, ParameterError
from mimika.face.heads import DEFAULT_HEAD
from mimika.web.glb import gltf_bytes
from mimika.web.heads import HeadCache, check_head, head_infos

log = logging.getLogger(__name__)

#: newsreader modules that may offer their own MP4 export (``render_project(project, path)``)
VIDEO_MODULES = ("mimika.news", "mimika.newsreader")
#: pose GLBs kept (a character's is 23 MB)
POSES = 3
#: synthesised sentences kept (also at most half of ``max_cache_mb``)
SENTENCES = 256


@dataclass
class SpeechSegment:
    """One synthesised sentence placed at ``t0`` seconds of the whole utterance."""

    text: str
    char0: int
    t0: float
    utterance: Any  # mimika.speech.Utterance (sentence-local times)
    mouth: Any  # AUTrack of the sentence's mouth AUs (sentence-local)
    #: behaviour tracks by (layers, fps), filled by mimika.studio.speaking
    behaviour: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(self.utterance.duration)


@dataclass
class SpeechEntry:
    """A spoken text: its segments in order (complete once ``done``)."""

    key: str
    text: str
    lang: str
    rate: int
    segments: list[SpeechSegment] = field(default_factory=list)
    done: bool = False

    @property
    def duration(self) -> float:
        return sum(s.duration for s in self.segments)

    @property
    def nbytes(self) -> int:
        """Memory of the audio and mouth frames it holds."""
        return sum(s.utterance.audio.nbytes + s.mouth.values.nbytes for s in self.segments)

    def audio(self) -> tuple[np.ndarray, int]:
        sr = self.segments[0].utterance.sr if self.segments else 22050
        parts = [s.utterance.audio for s in self.segments]
        return (np.concatenate(parts) if parts else np.zeros(0, np.float32)), int(sr)


def speech_key(text: str, lang: str, rate: int) -> str:
    h = hashlib.sha1(f"{lang}|{rate}|{text}".encode()).hexdigest()
    return h[:20]


class StudioState:
    """Everything the routers share.

    Parameters
    ----------
    projects_dir : folder of project JSON files (created if missing)
    head : ``builtin``, ``ict`` or a glTF/GLB/VRM character file
    library_path : the user expression library (default: the user's library)
    """

    def __init__(self, projects_dir: str | Path, *, head: str = DEFAULT_HEAD,
                 library_path: str | Path | None = None, controller_path: str | Path | None = None,
                 speech_cache: int = 32, heads_cache: int = 2):
        self.projects_dir = Path(projects_dir)
        self.projects_dir.mkdir(parents=True, exist_ok=True)
        self.head_name = check_head(head)
        self.library_path = Path(library_path) if library_path is not None else None
        self.controller_path = controller_path
        self._heads = HeadCache(heads_cache)
        self._poses: OrderedDict[tuple, bytes] = OrderedDict()
        self._sentences: OrderedDict[tuple, Any] = OrderedDict()
        self._sentence_bytes = 0
        self._pose_lock = threading.Lock()
        self._lib_lock = threading.Lock()
        self.espeak_lock = threading.Lock()  # espeak-ng is not re-entrant
        self._speech: OrderedDict[str, SpeechEntry] = OrderedDict()
        self._speech_lock = threading.Lock()
        self._speech_max = speech_cache
        self._ctl_lock = threading.Lock()
        self._ctl: Any = None
        self._ctl_error: str | None = None
        self._ctl_tried = False

    # -- head ---------------------------------------------------------------------------------
    def head(self, name: str | None = None) -> str:
        """``name`` checked against :func:`list_heads` (default: the studio's start-up head)."""
        if name is None or name == self.head_name:
            return self.head_name
        infos = {h.name: h for h in self.head_infos()}
        if name not in infos:
            raise ParameterError(f"there is no head called {name!r}; heads: "
                                 f"{', '.join(infos)}")
        if not infos[name].available:
            raise DataError(f"the {name} head is not installed on this computer (see "
                            "'mimika heads')")
        return name

    def head_infos(self) -> list[Any]:
        """The heads the page offers: :func:`head_infos` plus the start-up head when it is a
        file (a character file or glTF avatar)."""
        infos = head_infos()
        if self.head_name not in {h.name for h in infos}:
            from mimika.face.heads import HeadInfo

            infos.append(HeadInfo(self.head_name, "file", True, f"from {self.head_name}"))
        return infos

    def head_names(self) -> list[str]:
        return [h.name for h in self.head_infos()]

    def rig(self, name: str | None = None) -> Any:
        """The rig of head ``name`` (loaded once; the last few heads stay loaded)."""
        return self._heads.rig(self.head(name))

    def glb(self, name: str | None = None) -> tuple[bytes, str]:
        """Head ``name`` as GLB (no animation) and its ETag; built once per head."""
        return self._heads.glb(self.head(name))

    def pose_glb(self, name: str | None, aus: dict[str, float], *, fps: float,
                 label: str) -> bytes:
        """Head ``name`` posed by ``aus`` as GLB (``label`` names its scene), kept for the
        last :data:`POSES` poses; every pose of a head shares its encoded textures
        (:mod:`mimika.io.gltf`), so a new pose of a character takes 0.2 s, not 2 s."""
        from mimika.tracks import AUTrack

        key = (self.head(name), label, float(fps),
               tuple(sorted((str(k), float(v)) for k, v in aus.items())))
        with self._pose_lock:
            if key in self._poses:
                self._poses.move_to_end(key)
                return self._poses[key]
        data = gltf_bytes(self.rig(name), AUTrack.constant(aus, n_frames=1, fps=fps),
                          name=label, keep=True)
        with self._pose_lock:
            self._poses[key] = data
            while len(self._poses) > POSES:
                self._poses.popitem(last=False)
        return data

    def head_info(self, name: str | None = None) -> dict[str, Any]:
        """Supported AUs by FACS group, the rigid motions the page applies to joints and the
        face's frame (centre, height, width in metres) for the camera presets."""
        from mimika.facs import AU_CATALOGUE
        from mimika.io.gltf import SCALE, rig_motion
        from mimika.render.camera import face_frame

        rig = self.rig(name)
        motion = rig_motion(rig)
        sup = list(rig.supported)
        groups: dict[str, list[dict[str, Any]]] = {g: [] for g in GROUPS}
        for code in sup:
            if len(code) != 4:
                continue
            a = AU_CATALOGUE[code]
            if a.group in groups:
                groups[a.group].append({"code": code, "name": a.name,
                                        "sided": bool(a.sided and code + "L" in sup)})
        centre, height, width = face_frame(rig.head)
        return {
            "head": self.head(name),
            "aus": sup,
            "groups": [{"name": g, "aus": v} for g, v in groups.items() if v],
            "motion": {k: {c: [float(x) for x in np.asarray(v).ravel()]
                           for c, v in motion[k].items()}
                       for k in ("head_rot", "head_tr", "eye_rot")},
            "scale": SCALE,
            "frame": {"centre": [float(x) * SCALE for x in centre],
                      "height": float(height) * SCALE, "width": float(width) * SCALE,
                      "eye_y": float(rig.head.landmark_points()[36:48, 1].mean()) * SCALE,
                      "body": any(o.category == "body" for o in rig.head.objects)},
        }

    # -- expression library ------------------------------------------------------------------
    def library(self) -> Any:
        from mimika.knowledge import ExpressionLibrary

        return ExpressionLibrary(self.library_path)

    @property
    def library_lock(self) -> threading.Lock:
        return self._lib_lock

    # -- speech cache -------------------------------------------------------------------------
    def put_speech(self, entry: SpeechEntry) -> None:
        """Cache ``entry``; the oldest go once over ``speech_cache`` entries or
        ``max_cache_mb`` megabytes (:mod:`mimika.limits`), the newest always stays."""
        cap = limits.current().max_cache_mb * 1e6
        with self._speech_lock:
            self._speech[entry.key] = entry
            self._speech.move_to_end(entry.key)
            size = sum(e.nbytes for e in self._speech.values())
            while len(self._speech) > 1 and (len(self._speech) > self._speech_max or
                                             size > cap):
                size -= self._speech.popitem(last=False)[1].nbytes

    def get_speech(self, key: str) -> SpeechEntry | None:
        with self._speech_lock:
            e = self._speech.get(key)
            if e is not None:
                self._speech.move_to_end(key)
            return e

    def sentence(self, key: tuple) -> Any:
        """The synthesised utterance of one sentence ``(text, lang, rate)``, or None: a
        sentence spoken before, alone or in another text, is not synthesised again."""
        with self._speech_lock:
            utt = self._sentences.get(key)
            if utt is not None:
                self._sentences.move_to_end(key)
            return utt

    def put_sentence(self, key: tuple, utt: Any) -> None:
        """Keep ``utt``; the oldest go over :data:`SENTENCES` or half of ``max_cache_mb``."""
        cap = limits.current().max_cache_mb * 1e6 / 2
        with self._speech_lock:
            old = self._sentences.pop(key, None)
            self._sentence_bytes += utt.audio.nbytes - (old.audio.nbytes if old else 0)
            self._sentences[key] = utt
            while len(self._sentences) > 1 and (len(self._sentences) > SENTENCES or
                                                self._sentence_bytes > cap):
                self._sentence_bytes -= self._sentences.popitem(last=False)[1].audio.nbytes

    # -- optional features -------------------------------------------------------------------
    def controller(self) -> tuple[Any, str | None]:
        """The WGAN latent controller, or (None, reason) when mimika.learn or a model is missing."""
        with self._ctl_lock:
            if not self._ctl_tried:
                self._ctl_tried = True
                try:
                    from mimika.learn.controller import Controller

                    self._ctl = Controller.load(self.controller_path)
                except (ImportError, MimikaError, OSError, RuntimeError, KeyError,
                        ValueError) as e:
                    self._ctl_error = f"latent sliders unavailable: {e}"
                    log.info("studio: %s", self._ctl_error)
            return self._ctl, self._ctl_error

    @staticmethod
    def mp4_unavailable() -> str | None:
        """None when MP4 export works (studio renderer or a newsreader module), else why not."""
        from mimika.studio.video import available

        return available()

    @staticmethod
    def video_module() -> str | None:
        """Name of an importable newsreader module with its own MP4 export, else None."""
        import importlib

        for name in VIDEO_MODULES:
            try:
                if importlib.util.find_spec(name) is not None and any(
                        callable(getattr(importlib.import_module(name), f, None))
                        for f in ("render_project", "render_mp4")):
                    return name
            except (ImportError, ValueError, MimikaError):
                continue
        return None


GROUPS = ("upper face", "lower face linear", "lower face orbital", "head", "eyes")
