"""Rendering a video in worker processes gives the same frames as rendering here."""

import numpy as np
import pytest

from mimika.errors import RenderError
from mimika.render.camera import frame_head
from mimika.render.lighting import NEWS as NEWS_LIGHTING
from mimika.render.parallel import RenderPool, default_workers, render_track
from mimika.render.skin import SkinParams

pytestmark = pytest.mark.render
SIZE = (160, 120)
CHANNELS = ["AU12", "AU26", "AU51"]


def _values(n=9):
    return np.random.default_rng(0).uniform(0, 1, (n, len(CHANNELS))).astype(np.float32)


def test_two_workers_give_the_frames_of_one(builtin_rig):
    cam = frame_head(builtin_rig.head, "front", aspect=SIZE[0] / SIZE[1])
    kw = dict(camera=cam, size=SIZE, skin=SkinParams(refresh=3), lighting=NEWS_LIGHTING,
              chunk=3)
    here = list(render_track(builtin_rig, _values(), CHANNELS, workers=1, **kw))
    pooled = list(render_track(builtin_rig, _values(), CHANNELS, workers=2, **kw))
    assert len(here) == len(pooled) == 9
    for a, b in zip(here, pooled, strict=True):
        assert np.array_equal(a, b)
    # the frames move: the chunks are not all the same image
    assert np.abs(here[0].astype(int) - here[4].astype(int)).max() > 20


def test_frames_handed_out_without_copies_stay_intact_while_their_memory_is_reused(
        builtin_rig):
    """The frames live in shared memory blocks that are reused once their frames are dropped:
    frames taken one at a time (as a video writer does) match the frames drawn here, a frame
    still held keeps its block from being drawn over, and no block is left behind."""
    import glob
    import os

    from mimika.render import parallel

    cam = frame_head(builtin_rig.head, "front", aspect=SIZE[0] / SIZE[1])
    kw = dict(camera=cam, size=SIZE, skin=SkinParams(refresh=3), lighting=NEWS_LIGHTING,
              chunk=2)
    values = _values(20)
    here = list(render_track(builtin_rig, values, CHANNELS, workers=1, **kw))
    made = []
    take = parallel._Ring.take
    parallel._Ring.take = lambda ring, size: made.append(take(ring, size)) or made[-1]
    try:
        held, seen = None, []
        for i, img in enumerate(render_track(builtin_rig, values, CHANNELS, workers=2, **kw)):
            held = img if i == 1 else held  # kept while nine more chunks are drawn
            seen.append(img.copy())
    finally:
        parallel._Ring.take = take
    for a, b in zip(here, seen, strict=True):
        assert np.array_equal(a, b)
    assert np.array_equal(held, here[1])
    assert len(set(made)) < len(made) == 10  # blocks were drawn into again
    pid = os.getpid()
    assert not glob.glob(f"/dev/shm/{parallel.FRAMES}{pid}-*")


def test_a_pool_started_ahead_gives_the_same_frames(builtin_rig):
    cam = frame_head(builtin_rig.head, "front", aspect=SIZE[0] / SIZE[1])
    kw = dict(camera=cam, size=SIZE, skin=SkinParams(refresh=3), lighting=NEWS_LIGHTING)
    here = list(render_track(builtin_rig, _values(), CHANNELS, workers=1, chunk=3, **kw))
    with RenderPool(builtin_rig, workers=2, **kw) as pool:  # set up while this one waits
        pooled = list(render_track(builtin_rig, _values(), CHANNELS, chunk=3, pool=pool, **kw))
    assert len(pooled) == 9
    for a, b in zip(here, pooled, strict=True):
        assert np.array_equal(a, b)


def test_a_failing_worker_is_one_render_error_with_the_way_out(builtin_rig):
    cam = frame_head(builtin_rig.head, "front", aspect=1.0)
    with pytest.raises(RenderError, match="workers=1"):
        list(render_track(builtin_rig, _values(4), CHANNELS, camera=cam, size=(0, 0),
                          chunk=2, workers=2))


def test_short_clips_render_in_this_process():
    assert default_workers(100, 50) == 1
    assert default_workers(10_000, 50) >= 1


def test_a_script_that_renders_at_import_fails_with_the_way_out_instead_of_hanging(tmp_path):
    """Spawned workers re-run the script that started them; without a main guard they die
    at once. The script's process gets a render error naming the guard (it used to block
    forever writing the rig into a dead worker's pipe); nothing is left in /dev/shm."""
    import glob
    import os
    import subprocess
    import sys
    from pathlib import Path

    import mimika

    script = tmp_path / "unguarded.py"
    script.write_text(
        "import numpy as np\n"
        "from mimika.face.heads import load_head\n"
        "from mimika.render.camera import frame_head\n"
        "from mimika.render.parallel import render_track\n"
        "_, rig = load_head('builtin')\n"
        "cam = frame_head(rig.head, 'front', aspect=1.0)\n"
        "values = np.zeros((6, 1), np.float32)\n"
        "frames = list(render_track(rig, values, ['AU12'], camera=cam, size=(32, 32), chunk=2,"
        " workers=2))\n"
        "print('rendered', len(frames))\n")
    before = set(glob.glob("/dev/shm/mimika-frames-*"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(Path(mimika.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]))
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=240, env=env, cwd=tmp_path)
    assert p.returncode == 1 and "rendered" not in p.stdout
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("mimika.errors.RenderError") and "__main__" in last, p.stderr[-2000:]
    assert set(glob.glob("/dev/shm/mimika-frames-*")) <= before
