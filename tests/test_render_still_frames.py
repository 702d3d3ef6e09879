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
