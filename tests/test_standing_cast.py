"""A silhouette lifted standing only where the view can show it standing (``lift.silhouette.StandingRows.holds``).

From steeply above, the rays through a silhouette's rows run nearly along the vertical plane through its foot:
cast on it they meet it metres away, above the camera or under the ground. The bundled desk, a top-down photo,
built with ``--shape extrude`` made its coin 25 m across that way, a size ``simulate`` refuses. Such a cast
measures nothing: the object is lifted from above instead, at the size the camera's distance allows."""

from __future__ import annotations

import numpy as np
import pytest

from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.lift.silhouette import StandingRows, lift_silhouette
from physomni_usd.settings import LiftSettings

#: 320×240, 50° across, 1 m above the ground, looking down 82°: the desk's view.
STEEP = PinholeCamera(320, 240, 50.0, 82.0, (0.0, 0.0, 1.0))
#: the same camera looking down 20°: a side view.
SIDE = PinholeCamera(320, 240, 50.0, 20.0, (0.0, 0.0, 1.0))


def _mask(rows, cols, shape=(240, 320)):
    m = np.zeros(shape, bool)
    m[rows[0]:rows[1], cols[0]:cols[1]] = True
    return m


@pytest.mark.parametrize("shape", ["extrude", "round"])
def test_a_steep_view_lifts_a_forced_shape_from_above_at_the_cameras_scale(shape):
    # a small outline just below the image's centre, where the rows' rays cross under the camera
    mask = _mask((140, 165), (150, 175))
    seen = StandingRows.cast(mask, STEEP, LiftSettings(shape=shape), 0.0, None)
    assert not seen.holds()
    lifted = lift_silhouette(mask, STEEP, LiftSettings(shape=shape))
    extent = np.ptp(lifted.vertices, axis=0)
    assert lifted.info["mode"] == "footprint", lifted.info
    assert extent.max() < 0.5 * STEEP.origin[2], extent  # a thing on the ground, under a camera 1 m up


def test_a_side_view_still_lifts_the_forced_shape_standing():
    mask = _mask((120, 200), (140, 180))
    seen = StandingRows.cast(mask, SIDE, LiftSettings(shape="extrude"), 0.0, None)
    assert seen.holds()
    lifted = lift_silhouette(mask, SIDE, LiftSettings(shape="extrude"))
    assert lifted.info["mode"] == "standing" and lifted.shape == "extrude"
    assert np.ptp(lifted.vertices[:, 2]) == pytest.approx(float(seen.z.max() - seen.z.min()), rel=1e-6)
