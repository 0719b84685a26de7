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
