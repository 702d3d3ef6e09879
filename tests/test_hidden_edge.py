"""A supporter's hidden part is completed from its own colours, not from the occluder's edge: a dark coin lying
on a light card, drawn anti-aliased with a contact shadow as a renderer (and a camera) draws it, leaves the
card's pixels along its rim darkened; the card's texture where the coin hid it is the card's colour, so that
no grey disc is left in the card once the coin is pushed away."""

from __future__ import annotations

import cv2
import numpy as np

from physomni_usd.perceive.amodal import complete
from physomni_usd.texture.hidden import edge_band
from physomni_usd.texture.objects import completed_crop

H, W = 240, 320
CARD = np.array((205, 198, 196), float)
COIN = np.array((60, 70, 80), float)
SS = 4  # supersampling of the synthetic photo: the coin's rim is anti-aliased


def _coin_on_card(rng):
    """The photo, the card's and the coin's visible masks (coverage over one half), the card's whole outline."""
    card = np.zeros((H * SS, W * SS), np.uint8)
    cv2.rectangle(card, (70 * SS, 90 * SS), (190 * SS, 160 * SS), 1, -1)
    coin = np.zeros_like(card)
    cv2.circle(coin, (120 * SS, 125 * SS), 9 * SS, 1, -1)
    cover = lambda m: cv2.resize(m.astype(np.float32), (W, H), interpolation=cv2.INTER_AREA)
    card_c, coin_c = cover(card), cover(coin)
    # the coin's contact shadow: the card darkens towards the coin's rim
    shadow = 1 - 0.35 * np.clip(cv2.GaussianBlur(coin_c, (0, 0), 1.0) * 1.6, 0, 1)
    photo = np.full((H, W, 3), 120.0)
    photo = photo * (1 - card_c[..., None]) + (CARD * shadow[..., None]) * card_c[..., None]
    photo = photo * (1 - coin_c[..., None]) + COIN * coin_c[..., None]
    photo = np.clip(photo + rng.normal(0, 1.5, photo.shape), 0, 255).astype(np.uint8)
    coin_m = coin_c > 0.5
    card_m = (card_c > 0.5) & ~coin_m
    return photo, card_m, coin_m, card_c > 0.5


def test_the_cards_part_under_the_coin_takes_the_cards_colour():
    photo, card, coin, whole = _coin_on_card(np.random.default_rng(3))
    amodal = complete([card, coin])[0].amodal
    assert (amodal & coin).sum() >= 0.9 * coin.sum()  # the card is completed under the coin
    rgba, (x0, y0) = completed_crop(photo, card, amodal)
    hole = (amodal & coin)[y0:y0 + rgba.shape[0], x0:x0 + rgba.shape[1]]
    filled = rgba[..., :3][hole].astype(float)
    # the card's own colour, as the photo shows it away from the coin
    far = card & (cv2.distanceTransform((~coin).astype(np.uint8), cv2.DIST_L2, 5) > 8)
    own = photo[far].astype(float).mean(0)
    assert np.abs(filled.mean(0) - own).max() <= 4, (filled.mean(0), own)
    # no ring of darker pixels is left where the coin's rim was
    ring = (card & (cv2.distanceTransform((~coin).astype(np.uint8), cv2.DIST_L2, 5) <= 1.5))
    ring = ring[y0:y0 + rgba.shape[0], x0:x0 + rgba.shape[1]]
    assert np.abs(rgba[..., :3][ring].astype(float).mean(0) - own).max() <= 6


def test_the_rim_repainted_is_not_the_photos_pixels():
    # the frame shows the photo wherever an object's texture is at 255 and it has not moved: the card's rim
    # along the coin, repainted, is marked apart, or the coin's dark edge rings its place once it is pushed
    photo, card, coin, _ = _coin_on_card(np.random.default_rng(4))
    amodal = complete([card, coin])[0].amodal
    rim = edge_band(card, amodal & ~card)
    dark = card & (photo.astype(float).mean(2) < CARD.mean() - 25)
    assert dark.any() and (dark & ~rim).sum() == 0
    assert not (rim & (cv2.distanceTransform((~coin).astype(np.uint8), cv2.DIST_L2, 5) > 6)).any()
