"""Frames of the virtual camera: static backdrop + blurred pendulum, lit, noisy, 8-bit.

The camera never moves, so every pixel's world coordinates, the backdrop and the lighting
are computed once (:class:`FrameRenderer`); per frame only the pixel box around the moving
pendulum is rasterised (:func:`pendtrack.render.raster.raster_pendulum`).
"""

from __future__ import annotations

import numpy as np

from pendtrack.render.backdrop import build_backdrop, build_hand
from pendtrack.render.raster import raster_pendulum
from pendtrack.render.scene import Scene

NOISE_BANK = 2  # pre-drawn noise frames
NOISE_MARGIN = 64  # extra rows/columns of each, so a random crop gives a fresh pattern [px]
FULL_SCALE = 255.0  # reflectance 1 under light 1 -> this 8-bit level


class FrameRenderer:
    """Renders frames of one scene for given sub-sample angles.

    Parameters
    ----------
    scene, alley, gradient, vignetting
        The scene, its alley and its lighting, as :func:`pendtrack.render.backdrop.build_backdrop`
        takes them.
    noise_sigma : float
        Sensor noise, standard deviation in 8-bit levels (0: none).
    seed : int
        Seeds the wall's texture and the noise; the same seed and the same sequence of
        calls give identical frames.
    use_numba : bool
        Use the compiled raster kernel (default) or its pure-Python twin.
    hand_theta : float, optional
        A hand grips the bob at this angle [rad] in the frames that ask for it (``hand`` of
        :meth:`render`); None: no hand.
    """

    def __init__(self, scene: Scene, *, alley: bool, gradient: float, vignetting: float, noise_sigma: float,
                 seed: int, use_numba: bool = True, hand_theta: float | None = None) -> None:
        self.scene = scene
        self._use_numba = use_numba
        self._rng = np.random.default_rng(seed)
        self._x, self._y, self._size = scene.pixel_world_maps(0.0)
        self._parts = scene.parts()
        backdrop = build_backdrop(scene, alley=alley, gradient=gradient, vignetting=vignetting, rng=self._rng)
        self._light = backdrop.light[..., None] * np.float32(FULL_SCALE)
        self._back = backdrop.back * self._light
        self._front_alpha = None if backdrop.front_alpha is None else backdrop.front_alpha[..., None]
        self._front = None if backdrop.front is None else backdrop.front * self._light
        self._front_row0 = 0
        if self._front_alpha is not None:
            rows = np.flatnonzero(self._front_alpha.max(axis=(1, 2)) > 0)
            self._front_row0 = int(rows[0]) if rows.size else scene.height
        self._static = self._over_front(self._back.copy(), (0, 0, scene.width, scene.height))
        self._hand = None
        if hand_theta is not None:
            hand = build_hand(scene, hand_theta)
            x0, y0, x1, y1 = hand.box
            self._hand = (hand.box, hand.alpha, hand.colour * self._light[y0:y1, x0:x1])
        self._noise_sigma = float(noise_sigma)
        self._noise = None
        if noise_sigma > 0:
            shape = (NOISE_BANK, scene.height + NOISE_MARGIN, scene.width + NOISE_MARGIN, 3)
            self._noise = (self._rng.standard_normal(shape, dtype=np.float32) * np.float32(noise_sigma))

    def _over_front(self, region: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
        """Composite the alley's front slab over ``region`` (the pixels of ``box``), in place."""
        if self._front is None:
            return region
        x0, y0, x1, y1 = box
        top = max(y0, self._front_row0)
        if top < y1:
            fa = self._front_alpha[top:y1, x0:x1]
            part = region[top - y0:]
            part *= 1 - fa
            part += self._front[top:y1, x0:x1] * fa
        return region

    def render_linear(self, thetas: np.ndarray, *, hand: float = 0.0) -> np.ndarray:
        """Noise-free frame, float32 (H, W, 3) BGR in 8-bit levels (not clipped).

        Parameters
        ----------
        thetas : ndarray, shape (n,)
            Pendulum angles [rad] sampled evenly over the exposure (one value: no blur).
        hand : float
            Share of the exposure during which the hand holds the bob, in [0, 1]
            (needs ``hand_theta``; 0: no hand in this frame).
        """
        frame = self._static.copy()
        box = self.scene.bbox_px(np.atleast_1d(thetas))
        x0, y0, x1, y1 = box
        if x1 > x0 and y1 > y0:
            region, _ = raster_pendulum(self._x, self._y, self._size, self._light, self._back, box,
                                        np.atleast_1d(thetas), self._parts, use_numba=self._use_numba)
            frame[y0:y1, x0:x1] = self._over_front(region, box)
        if hand > 0 and self._hand is not None:
            (x0, y0, x1, y1), alpha, colour = self._hand
            cov = alpha * np.float32(hand)
            part = frame[y0:y1, x0:x1]
            part *= 1 - cov
            part += colour * cov
        return frame

    def render(self, thetas: np.ndarray, *, hand: float = 0.0) -> np.ndarray:
        """Frame as the sensor delivers it: noisy, clipped, uint8 (H, W, 3) BGR.

        Each call draws the next noise pattern from the seeded generator (a random crop of
        a pre-drawn noise bank), so frames depend on the order of calls. ``hand`` as in
        :meth:`render_linear`.
        """
        frame = self.render_linear(thetas, hand=hand)
        if self._noise is not None:
            k = int(self._rng.integers(NOISE_BANK))
            dy, dx = (int(v) for v in self._rng.integers(0, NOISE_MARGIN + 1, size=2))
            frame += self._noise[k, dy:dy + self.scene.height, dx:dx + self.scene.width]
        np.clip(frame, 0.0, 255.0, out=frame)
        frame += 0.5  # round to nearest
        return frame.astype(np.uint8)
