"""Each connected part of the plate's hole is filled on its own: what the rest of the hole is, near or far,
changes none of its pixels (a fill shared out among the parts by their size changed the whole plate when one
part changed by a few pixels)."""

from __future__ import annotations

import numpy as np
import pytest

from physomni_usd.texture.exemplar import EXEMPLAR_HOLE_PIXELS, hole_windows
from physomni_usd.texture.fill import fill_hole


def _wood_and_holes():
    """A 520×1100 grained, shaded surface; a 150×150 hole on its left and a 250×260 one far to its right (their
    windows and every low-pass of the fill apart)."""
    rng = np.random.default_rng(8)
    h, w = 520, 1100
    y, x = np.mgrid[:h, :w].astype(np.float32)
    wood = 120 + 25 * np.sin(x / 5.0 + 2 * np.sin(y / 19.0)) + 0.04 * y + rng.normal(0, 4, (h, w))
    photo = np.clip(wood[..., None] * np.float32([1.0, 0.85, 0.65]), 0, 255).astype(np.uint8)
    left = np.zeros((h, w), bool)
    left[180:330, 120:270] = True
    right = np.zeros((h, w), bool)
    right[130:380, 700:960] = True
    return photo, left, right


def test_every_part_has_the_whole_budget_whatever_the_others():
    _, left, right = _wood_and_holes()
    alone = [b for *_, b in hole_windows(left)]
    both = [b for *_, b in hole_windows(left | right)]
    assert alone == [EXEMPLAR_HOLE_PIXELS] and both == [EXEMPLAR_HOLE_PIXELS] * 2


@pytest.mark.parametrize("method", ["faded", "exemplar"])
def test_a_part_of_the_hole_is_filled_alike_whatever_the_rest_of_the_hole(method):
    photo, left, right = _wood_and_holes()
    alone = fill_hole(photo, left, method, feather=8)
    both = fill_hole(photo, left | right, method, feather=8)
    smaller = right.copy()
    smaller[130:140, 700:760] = False  # the far part a little smaller
    less = fill_hole(photo, left | smaller, method, feather=8)
    # shared out by size the left part's budget was 3086 reduced pixels beside the right part, 3107 beside the
    # smaller one, 12000 alone: of its 22500 pixels the faded fill changed 20412 (4715 by more than 20 levels)
    # between the first two fills and 19014 (4708) between the last two
    assert np.array_equal(alone[left], both[left])
    assert np.array_equal(both[left], less[left])
    assert not np.array_equal(alone[right], both[right])  # the right part is filled at all
