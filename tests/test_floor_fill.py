"""The faded fill on a checked floor seen in perspective: filled top-down under the known camera, the checks
stay in step (texture/floor.py)."""

import numpy as np

from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.texture.fill import fill_hole
from physomni_usd.texture.floor import fill_on_ground


def _checked_floor(camera, check_m=0.2):
    """The photo of a floor of light and dark checks ``check_m`` wide under ``camera``, grey sky above it."""
    v, u = np.mgrid[0:camera.height, 0:camera.width] + 0.5
    p = camera.ground_points(u, v)
    on = np.isfinite(p[..., 0])
    parity = (np.floor(np.nan_to_num(p[..., 0]) / check_m) + np.floor(np.nan_to_num(p[..., 1]) / check_m)) % 2
    img = np.where(parity[..., None] > 0, np.array([200, 190, 170]), np.array([70, 60, 80]))
    img = np.where(on[..., None], img, np.array([150, 160, 170]))
    return img.astype(np.uint8)


def test_checks_in_perspective_filled_top_down_stay_in_step():
    camera = PinholeCamera(200, 150, 60.0, 20.0, (0.0, 0.0, 1.0))  # horizon at row 28
    photo = _checked_floor(camera)
    v, u = np.mgrid[0:150, 0:200]
    hole = (u - 110) ** 2 + ((v - 100) * 1.4) ** 2 < 24 ** 2  # a hole some checks wide, on the floor
    broken = photo.copy()
    broken[hole] = 255
    error = lambda img: float(np.abs(img.astype(float) - photo.astype(float)).mean(-1)[hole].mean())  # noqa: E731
    flat = error(fill_hole(broken, hole, "faded"))
    top_down = error(fill_hole(broken, hole, "faded", camera=camera))
    # the image-plane copies fall between the receding checks; top-down, the checks are equal and copies line up
    assert top_down < 0.75 * flat, (top_down, flat)
    # off the floor nothing changes: a hole in the sky keeps the image-plane fill, no top-down view is made
    sky = (u - 100) ** 2 + (v - 12) ** 2 < 6 ** 2
    plane = fill_hole(photo, sky, "faded")

    def never(image, hole):
        raise AssertionError("a hole off the floor was filled top-down")

    assert np.array_equal(fill_on_ground(photo, sky, camera, never, plane), plane)
