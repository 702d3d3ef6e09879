"""A video's frames where nothing moved are the last frame drawn again (rendering/video.py, STILL_PX): the
video is the one drawn frame by frame, to within a level, at the cost of the frames where something moves."""

import numpy as np
from pxr import Usd

from physomni_usd.rendering import video
from physomni_usd.rendering.video import ShotRenderer
from physomni_usd.settings import RenderSettings


def test_frames_at_rest_are_not_drawn_again_and_look_the_same(shot):
    stage = Usd.Stage.Open(str(shot["shot"]))
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    every = ShotRenderer(stage, RenderSettings())
    reusing = ShotRenderer(stage, RenderSettings())
    reusing.reuse_still = True
    casts = []
    cast = reusing.caster.cast
    reusing.caster.cast = lambda *a, **k: (casts.append(1), cast(*a, **k))[1]
    worst, still = 0, 0
    for t in range(start, end + 1):
        a, state_a = every.render(float(t))
        n = len(casts)
        b, state_b = reusing.render(float(t))
        worst = max(worst, int(np.abs(a.astype(int) - b).max()))
        assert state_b.time == float(t) and b.shape == a.shape
        if len(casts) == n:  # given again: nothing moved from the frame last drawn
            still += 1
            drawn = reusing._last[2]
            assert every._pixel_motion(state_a.camera, state_a.points, drawn) < video.STILL_PX
    assert worst <= 1
    # the pushed box comes to rest within the shot: most of its frames are the last one drawn
    assert still >= (end - start + 1) // 3, (still, end - start + 1)


def test_a_renderer_draws_every_frame_unless_told(shot):
    """The preview edits the stage between frames and the passes read each frame's own rays: off by default."""
    stage = Usd.Stage.Open(str(shot["shot"]))
    r = ShotRenderer(stage, RenderSettings())
    assert r.reuse_still is False
    end = float(stage.GetEndTimeCode())
    casts = []
    cast = r.caster.cast
    r.caster.cast = lambda *a, **k: (casts.append(1), cast(*a, **k))[1]
    r.render(end)
    r.render(end)
    assert len(casts) == 2


def test_a_large_frame_sampled_over_its_region_looks_like_every_ray_cast(shot, monkeypatch):
    """A frame above WORK_PX casts rays on a grid of every step-th pixel over the region that can differ from the
    photo and interpolates texture coordinates between samples on one smooth surface: the first frame is still
    the photo exactly, and a moved object's frames differ from casting every ray only along seams."""
    stage = Usd.Stage.Open(str(shot["shot"]))
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    every = ShotRenderer(stage, RenderSettings())
    monkeypatch.setattr(video, "WORK_PX", max(every.width, every.height) / 3.0)
    sampled = ShotRenderer(stage, RenderSettings())
    sampled.reuse_still = True
    assert sampled._step == 3 and every._step == 1
    regions = []
    region = sampled._render_region
    sampled._render_region = lambda *a: (regions.append(1), region(*a))[1]
    first = None
    for t in range(start, end + 1):
        a, _ = every.render(float(t))
        sampled._last = None  # draw each frame, still or not
        b, _ = sampled.render(float(t))
        d = np.abs(a.astype(int) - b).max(-1)
        if first is None:
            first = int(d.max())
            assert first == 0  # the photo, exactly
        changed = np.any(a != sampled._region_setup()[0], axis=-1)  # where the frame is not the photo
        if changed.any():
            assert np.mean(d[changed] > 24) < 0.03, (t, np.mean(d[changed] > 24))
            assert np.mean(d) < 1.5
    assert len(regions) == end - start + 1
