"""The tuning of the marker tracking: :class:`TrackParams` (search windows, acceptance, template
evolution, acquisition timing, hole filling), validated when built, with the paper's values as defaults."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

REFINE_METHODS = ("quadratic", "centroid")


@dataclass(frozen=True, kw_only=True)
class TrackParams:
    """Tuning of :func:`track_frames`.

    Attributes
    ----------
    min_score : float
        Acceptance threshold on the normalised match score, in (-1, 1].
    search_margin_px : int
        Margin of the wide search window around the prediction [px].
    quick_margin_px : int
        Margin of the first, small search window when the prediction is reliable [px].
    evolution_rate : float
        Template evolution per ok frame, in [0, 1).
    refine : str
        ``"quadratic"``: quadric fit of the 3x3 scores around the peak; ``"centroid"``:
        feature-weighted centroid of the marker around the matched position.
    max_coast_frames : int
        After this many frames without an ok match the prediction is dropped and every
        frame is searched whole.
    min_contrast_ratio : float
        The matched patch's feature standard deviation must lie within
        ``[r, 1 / r]`` times the template's, r in (0, 1].
    acquire_step_s : float
        Until the marker is found, frames are searched this often [s]; the frames since
        the last search are then searched one by one (the marker is acquired in the first
        frame where it is visible).
    acquire_window_s : float
        Candidates are told apart by their motion over this time after acquisition [s].
    max_drift_px : float
        An evolving template whose content has moved further than this from the first
        template is shifted back onto it (re-anchored) [px of the template].
    hole_share : float
        Dips of the feature inside the marker narrower than a disc of this share of its
        radius are filled (:func:`pendtrack.track.match.fill_holes`) in the template and in
        every search window, so a sticker turning with a ball does not pull the match off
        its centre; 0 = off. Only pixels the filling lifts to half the marker's contrast
        change. 0.6: measured on the field renders (tests/field_run.py) of a sticker of 0.3
        radii 0.45 radii off a blue ball's centre (theta 2.57 -> 0.79 mrad RMS) and of 0.33
        radii on the paper's spot of 6 px (4.42 -> 1.46 mrad; 1.31 without the sticker),
        every other condition within 0.01 mrad of no filling; 0.8 fills a little more of
        the sticker's blur (0.72, 1.38 mrad) but bridges the gap between a dark ball and the
        dark floor just below it (0.24 -> 0.66 mrad).
    """

    min_score: float = 0.6
    search_margin_px: int = 48
    quick_margin_px: int = 6
    evolution_rate: float = 0.0
    refine: str = "quadratic"
    max_coast_frames: int = 30
    min_contrast_ratio: float = 0.3
    acquire_step_s: float = 0.05
    acquire_window_s: float = 0.5
    max_drift_px: float = 3.0
    hole_share: float = 0.6

    def __post_init__(self) -> None:
        if not (np.isfinite(self.acquire_step_s) and self.acquire_step_s > 0):
            raise ValueError(f"acquire_step_s must be > 0 s, got {self.acquire_step_s}")
        if not (np.isfinite(self.acquire_window_s) and self.acquire_window_s >= 0):
            raise ValueError(f"acquire_window_s must be >= 0 s, got {self.acquire_window_s}")
        if not (np.isfinite(self.hole_share) and 0 <= self.hole_share <= 2):
            raise ValueError(f"hole_share must be in [0, 2], got {self.hole_share}")
        if not (np.isfinite(self.max_drift_px) and self.max_drift_px > 0):
            raise ValueError(f"max_drift_px must be > 0 px, got {self.max_drift_px}")
        if not -1.0 < self.min_score <= 1.0:
            raise ValueError(f"min_score must be in (-1, 1], got {self.min_score}")
        if self.search_margin_px < 1 or self.quick_margin_px < 1:
            raise ValueError("search margins must be >= 1 px")
        if not 0.0 <= self.evolution_rate < 1.0:
            raise ValueError(f"evolution_rate must be in [0, 1), got {self.evolution_rate}")
        if not 0.0 < self.min_contrast_ratio <= 1.0:
            raise ValueError(f"min_contrast_ratio must be in (0, 1], got {self.min_contrast_ratio}")
        if self.refine not in REFINE_METHODS:
            raise ValueError(f"refine must be one of {REFINE_METHODS}, got {self.refine!r}")
