"""Frozen configuration dataclasses, loaded from ``configs/*.toml``.

The defaults below are the single source of truth; ``configs/default.toml`` documents
them with comments and a test checks that the two agree. A TOML file only needs the keys
it changes. Unknown sections or keys, values of the wrong type and values out of their range
(:data:`CHECKS`) are errors that name the file and the key, raised when the file is loaded,
before any stage runs.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, get_type_hints

from pendtrack.errors import ConfigError

PAPER_FPS = 120.0
SAVGOL_WINDOW_S = 25 / PAPER_FPS  # the paper's Savitzky-Golay window: 25 frames at 120 fps [s]
MEMORY_S = 100 / PAPER_FPS  # the paper's Grünwald–Letnikov memory: 100 frames at 120 fps [s]
# the file suffixes read as videos (batch's default extensions, discovery's inputs, run codes), any case
VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".m4v", ".mts", ".webm", ".mpg", ".mpeg", ".wmv", ".gif")
# radial projections of pendtrack.lens.fisheye (a lens's input; "none" and "rectilinear" do not bend rays)
LENS_PROJECTIONS = ("equisolid", "equidistant", "stereographic", "orthographic", "rectilinear", "none")
FIT_COSTS = ("xi2", "theta")  # fit cost: the paper's Xi^2 on A_theta, A_omega | least squares on theta
FIT_JACOBIANS = ("sensitivity", "fd")  # [fit] jacobian: forward sensitivity equations | finite differences
FIT_COORDINATES = ("decorrelated", "natural")
FIT_OFFSETS = ("auto", "always", "never")  # [fit] offset: fit theta's zero (theta_off) when not measured, always, never
TRACK_REFINE = ("quadratic", "centroid")  # sub-pixel refinement of the template match
LENS_CHECK_MODES = ("error", "warn", "off")  # what a lens that fits the track clearly worse than another does
RENDER_MARKER_COLOURS = ("pink", "dark", "blue")  # named looks of the rendered bob (or #RRGGBB)
RENDER_MARKER_SHAPES = ("spot", "ball", "shiny")  # a flat disc on the bar | a shaded sphere | a glossy one
RENDER_RIGS = ("bar", "string")  # the paper's bar | a ball on a string


@dataclass(frozen=True, kw_only=True)
class LensConfig:
    """Tracker-compatible radial distortion filter ("Fisheye" input, rectilinear output)."""

    projection: str = "equisolid"  # equisolid | equidistant | stereographic | orthographic | none
    fov_deg: float = 120.0  # input diagonal field of view [deg]
    fixed_pixels: float = 0.48  # radius of the circle that does not move, fraction of half-diagonal


@dataclass(frozen=True, kw_only=True)
class VideoConfig:
    fps: float = 0.0  # 0: time from the container's presentation timestamps; >0 overrides [1/s]
    start: float = 0.0  # first time read, from the video's first frame (which stays t = 0) [s]
    end: float = 0.0  # last time read [s]; 0 = to the last frame


@dataclass(frozen=True, kw_only=True)
class TrackConfig:
    marker_color: str = "pink"  # pink | red | orange | yellow | green | blue | dark | #RRGGBB
    roi: tuple[int, ...] = ()  # x, y, w, h of the marker in the first frame [px]; () finds it by colour
    search_margin_px: int = 48  # half-size margin of the search window around the prediction [px]
    min_score: float = 0.6  # acceptance threshold on the normalised match score (Tracker's automark)
    evolution_rate: float = 0.0  # template evolution per frame, 0 as in the paper
    quick_margin_px: int = 6  # margin of the first, small search window when the prediction is reliable [px]
    refine: str = "quadratic"  # sub-pixel refinement: quadratic (3x3 score quadric) | centroid
    max_coast_frames: int = 30  # frames without an ok match before every frame is searched whole
    min_contrast_ratio: float = 0.3  # matched patch contrast must be within [r, 1/r] of the template's
    track_in_corrected: bool = False  # True: track in lens-corrected frames (only the search window is remapped)
    acquire_step_s: float = 0.05  # before the marker is found, look for it every this often (then refine back) [s]
    acquire_window_s: float = 0.5  # candidates are told apart by their motion over this time after acquisition [s]
    max_drift_px: float = 3.0  # an evolving template is re-anchored on the first when it drifts further [px]
    hole_share: float = 0.6  # dips inside the marker narrower than this share of its radius are filled (a sticker) [1]


@dataclass(frozen=True, kw_only=True)
class AngleConfig:
    axle: tuple[float, ...] = ()  # x, y of the axle in corrected px; () fits a circle to the track
    rest_seconds: float = 2.0  # length of the final still stretch used as the zero of theta [s]
    rest_omega_max: float = 0.05  # the pendulum counts as still below this |omega| [rad/s]
    lens_check: str = "error"  # configured lens fits the track's circle clearly worse than another: error | warn | off
    lens_ratio: float = 2.0  # ... clearly = its circle residual is at least this many times the best lens' [1]


@dataclass(frozen=True, kw_only=True)
class KinematicsConfig:
    savgol_window_s: float = SAVGOL_WINDOW_S  # paper: 25 frames at 120 fps [s]
    savgol_order: int = 3  # cubic, as in the paper
    max_gap_s: float = 0.05  # gaps of not-ok samples up to this length are bridged [s]
    min_segment_s: float = 1.0  # shorter segments between long gaps are dropped [s]


@dataclass(frozen=True, kw_only=True)
class ModelsConfig:
    memory_s: float = MEMORY_S  # Grünwald–Letnikov memory: paper's 100 frames at 120 fps [s]
    full_history: bool = False  # True: the GL sum runs over the whole record
    # the predictor-corrector's largest step [s]: the paper's 1/120 s. A record sampled more coarsely
    # is integrated with sub-steps (memory kept as a duration), outputs at its samples: at the
    # sample step of 30 fps (Omega0 h ~ 0.17) the second-order scheme's phase error biased Omega0
    # by ~1e-3
    max_step_s: float = 1.0 / PAPER_FPS


@dataclass(frozen=True, kw_only=True)
class FitConfig:
    models: tuple[str, ...] = ("classic", "opa", "fractional")  # fitted by `run`
    cost: str = "xi2"  # xi2 (paper's eq. leastsquarescostfunction) | theta (plain least squares)
    n_starts: int = 150  # paper: 150 independent starts
    accept_ratio: float = 1.25  # paper's 5/4 rule: starts with Xi^2 <= 5/4 Xi^2_min
    start_spread: float = 0.5  # starts drawn within +-spread (relative) around the estimates
    omega0_spread: float = 0.01  # starts' Omega0 within +-spread (relative) of the model-free estimate
    seed: int = 0  # seed of the start draws (and of the bootstrap)
    # profile likelihood: standard errors per side (stderr_low, stderr_high) and, for a model with memory, the
    # scan along beta's valley that widens the intervals to quote (interval68, interval95); off, those are the
    # sandwich's value +- z stderr, which miss the truth more often than they say for the memory parameters
    profile: bool = True
    bootstrap: int = 0  # moving-block bootstrap refits for stderr_bootstrap; 0 = none
    start_budget: int = 30  # each start's fit of the whole record: at most this many Jacobians' worth of simulations
    ladder: bool = True  # each start fits a growing window (three periods, doubled up to the record): no phase slips
    # each window of the ladder this many times as long as the one before (models without memory: their
    # starts converge on the shorter windows, and many merge there)
    ladder_growth: float = 2.0
    # the same for the models with memory, whose shorter windows do not pin the memory (no start merges
    # there): a 4-fold step still carries Omega0 and the phase, for a third less CPU (docs/decisions.md)
    ladder_growth_memory: float = 4.0
    # a start of a model without memory whose cost on a shorter window of the ladder (at least 1/4 of the
    # record) exceeds this many times the lowest any start up to it reached there stops there; 0 = never.
    # 60-s bench record: the starts that ended accepted were at most 11x (classic) and 7.9x (OPA) the lowest
    # there (docs/decisions.md)
    hopeless_ratio: float = 30.0
    # the same for the models with memory; off: on the 60-s bench record fractional starts 500x the lowest
    # on the 23-s window still ended among the accepted ones (the memory is not pinned by a short window)
    hopeless_ratio_memory: float = 0.0
    # a start that, after a shorter window, is within this share of the start ranges' half-widths of a lower
    # start (every parameter) takes that start's end point (its path from there is the other's); 0 = never
    merge_tol: float = 1e-5
    trust_region_polish: bool = False  # finish the best fit by a trust-region least-squares run too (discovery: on)
    workers: int = 0  # processes for the starts; 0 = all cores (does not change the results)
    # fit theta's zero as a nuisance parameter (the measurement term "offset", theta_off) in `fit` and
    # `run`: auto = when the zero is not a measured rest (angle.parquet's zero_reference "vertical", or a
    # plain table), always, never
    offset: str = "auto"
    # a tracked video's frames in which the marker moved less than this many pixels (its turning points) are
    # left out of the cost, with every sample whose filter window reaches them: a compressed video codes a slow
    # marker's motion short there, up to a few pixels a frame (fitting.leastsq.samples.slow_frames); 0 = keep them
    slow_motion_px: float = 3.0
    # Jacobians of the Levenberg-Marquardt starts and the refine step: "sensitivity" = the forward
    # sensitivity equations integrated with the RK4 trajectory (models without memory; the others keep
    # finite differences), "fd" = finite differences (one simulation per parameter). The sandwich
    # standard errors always use central finite differences. Same minima as "fd" (classic, 60 s, 150
    # starts: Xi^2_min 1.8e-7 lower, values within 0.03 standard errors), 1.7x faster (benchmarks/bench_jacobian.py)
    jacobian: str = "sensitivity"
    # RK4 sub-step of the fitted models without memory, Omega h_sub <= substep_phase [rad] (2 sub-steps
    # at 120 fps; the simulation's own 0.015 rad gives 3); 0 = that own. Its error (<= 1e-6 rad over 60 s)
    # is 3000 times below the angle's noise: the same fits (Xi^2_min within 7e-7 relative, values within
    # 1e-4 standard errors) for 2/3 of the simulations' time (benchmarks/bench_fit_settings.py)
    substep_phase: float = 0.025
    # the same for the sensitivity Jacobian that steers each Levenberg-Marquardt iteration (1 sub-step at
    # 120 fps); 0 = substep_phase. Where a fit ends is set by its residuals whatever steers it there
    steer_phase: float = 0.05
    # the same for the residuals on the ladder's shorter windows (1 sub-step at 120 fps); 0 = substep_phase. They
    # only carry a start to the whole window, whose residuals use substep_phase: on the bench record the same
    # fits (Xi^2_min within 2e-15, every value and u_paper alike) for 15 % (classic) and 12 % (OPA) less CPU
    rung_phase: float = 0.05
    # the coordinates of the Levenberg-Marquardt steps: "decorrelated" = the damping amplitudes at data-derived
    # references (D = C3 x_ref^p; G2 0.5^beta a_ref^p_f) and the time-varying damping's rate and its relative
    # change (C4/(t_ref - t0), 1/(t_ref - t0)) (pendtrack.fitting.leastsq.coordinates); "natural" = the model's
    # parameters. Only the steps' path changes: every value is reported in the model's parameters
    coordinates: str = "decorrelated"
    # a joint fit of several records (pendtrack.fitting.joint): seeded random starts drawn within the spread of
    # the runs' own fits, after the data-derived ones (the pooled values, then each run's own values)
    joint_starts: int = 4


@dataclass(frozen=True, kw_only=True)
class RenderConfig:
    """The synthetic video (`pendtrack render`): camera, apparatus, motion, image quality.

    World lengths in m, measured in the pendulum's plane from the axle (x right, y down);
    the model's parameters come from ``params`` over the renderer's defaults
    (:data:`pendtrack.render.physics.DEFAULT_PARAMS`, Omega0 from the two-cuboid formula).
    """

    width: int = 1280  # [px]
    height: int = 720  # [px]
    fps: float = PAPER_FPS  # [1/s]
    seconds: float = 10.0  # [s]
    model: str = "standard"
    theta0: float = 3.0  # initial angle, near the top [rad]
    omega0: float = 0.0  # initial angular velocity [rad/s]
    seed: int = 0
    camera_distance_m: float = 0.58  # camera to axle [m]
    spot_distance_m: float = 0.26  # axle to the pink spot's centre [m]
    spot_radius_m: float = 0.012  # [m]
    bar_length_m: float = 0.52  # [m]
    bar_width_m: float = 0.02  # [m]
    disc_diameter_m: float = 0.06  # [m]
    tile_width_m: float = 0.18  # [m]
    exposure_s: float = 1 / 480  # shutter open time, sets the motion blur [s]
    noise_sigma: float = 2.0  # sensor noise, standard deviation in 8-bit levels
    crf: int = 20  # H.264 constant rate factor
    two_cuboid_x: float = 1.48  # X = lambda0/lambda1 of eq. consistencycheck
    two_cuboid_l0_m: float = 0.54  # l0 of eq. consistencycheck; also axle to the bar's far end [m]
    gravity: float = 9.81  # [m/s^2]
    params: tuple[str, ...] = ()  # model parameters "NAME=VALUE"; the others take the model's defaults
    tile_length_m: float = 0.0  # l1, tile length; 0 = no tile [m]
    alley: bool = False  # draw the alley's slabs near the bottom of the swing
    trial: int = 1  # trial number, last digit of the run code
    camera_offset_m: tuple[float, ...] = (0.05, 0.02)  # optical-axis point minus axle, in the plane, x right, y down [m]
    lens_projection: str = "equisolid"  # the camera's projection (pendtrack.lens.fisheye); none = a normal lens
    lens_fov_deg: float = 120.0  # the camera's diagonal field of view [deg]
    blur_step_px: float = 0.4  # max spot travel between motion-blur sub-samples [px]
    illumination_gradient: float = 0.3  # relative brightness change across the half diagonal [1]
    vignetting: float = 0.35  # relative darkening at the image corners [1]
    x264_preset: str = "veryfast"  # libx264 speed preset
    # field conditions (what users film): the marker's look, the rig, the hand, the camera's roll
    marker_color: str = "pink"  # the bob's colour: pink (the paper's spot) | dark | blue | #RRGGBB
    marker_shape: str = "spot"  # spot (a flat disc on the bar) | ball (a shaded sphere) | shiny (a glossy ball)
    rig: str = "bar"  # bar (the paper's bar, disc and tile) | string (a thin string to the bob, Omega0 = sqrt(g/L))
    sticker_color: str = ""  # a small sticker on the bob, off its centre: "" = none | pink | dark | blue | #RRGGBB
    sticker_radius_m: float = 0.004  # [m]
    hand_release_s: float = 0.0  # a hand holds the bob at theta0 until this time, then lets go; 0 = no hand [s]
    camera_roll_deg: float = 0.0  # camera rolled about its optical axis: theta in the image = theta + roll [deg]


@dataclass(frozen=True, kw_only=True)
class BatchConfig:
    """`pendtrack batch`: many run-coded videos, on local processes or a Dask cluster."""

    scheduler: str = "processes"  # processes (local worker processes) | tcp://HOST:PORT of a Dask scheduler
    workers: int = 0  # local worker processes; 0 = all cores (ignored with a Dask scheduler)
    threads_per_worker: int = 1  # BLAS/OpenMP/numba/OpenCV threads inside each worker
    inner_workers: int = 1  # [fit] and [discover] workers inside a batch run: 1 = no nested pools
    extensions: tuple[str, ...] = VIDEO_SUFFIXES  # video files, any case
    recursive: bool = False  # also look for videos in sub-folders of FOLDER
    omega0_models: tuple[str, ...] = ("fractional", "classic", "opa")  # Omega0 for the two-cuboid fit: first fitted
    report: bool = True  # write DIR/report.html (pendtrack.stages.report) at the end


@dataclass(frozen=True, kw_only=True)
class DiscoverConfig:
    """`pendtrack discover`: find what the baseline misses, extend it, measure the gain."""

    baseline: str = "standard"  # model the search starts from (any registered model)
    effects: tuple[str, ...] = ()  # catalogue effects to try; () = every one the baseline lacks
    train_fraction: float = 0.6  # held-out test: fit this first share of the record, predict the rest [1]
    delta_bic_max: float = -10.0  # keep an effect only if BIC drops below this (Kass-Raftery "very strong")
    heldout_z_min: float = 3.0  # ... and its held-out gain exceeds noise by this many standard deviations
    heldout_min_gain: float = 0.01  # ... and is at least this share of the held-out RMS [1]
    cv_blocks: int = 10  # measurement terms: interleaved blocks (even ones predict the odd ones and back) [1]
    max_effects: int = 3  # at most this many effects are added
    measurement: tuple[str, ...] = ("offset", "angle_scale")  # measurement terms tried before any effect; () = none
    max_combination: int = 2  # effects tried together when no single one earns its keep (1 = singles only)
    combination_pool: int = 4  # the singles with the best held-out gain that enter the combinations
    n_starts_baseline: int = 2  # multi-start fits of the baseline (data-derived starts, each polished)
    n_starts: int = 1  # random starts around the warm start per candidate fit (+ the scaled starts)
    workers: int = 0  # processes for the candidate fits; 0 = all cores
    analysis_rate_hz: float = 60.0  # faster records are decimated to >= this rate; 0 keeps every sample [1/s]
    # model + noise replicas calibrating the kinematic diagnostics: with 6, the hysteresis z of a correct model
    # exceeded 3 on 4 of 150 noise draws (a 5-dof spread's t tails), with 30 on 1 (docs/decisions.md)
    n_replicas: int = 30
    near_turning_fraction: float = 0.25  # "near a turning point": |omega| below this share of the peak [1]
    seed: int = 0  # seed of the fits' starts and of the replicas' noise


@dataclass(frozen=True, kw_only=True)
class Config:
    """The whole pipeline's configuration; each stage reads its sections."""

    lens: LensConfig = field(default_factory=LensConfig)
    video: VideoConfig = field(default_factory=VideoConfig)
    track: TrackConfig = field(default_factory=TrackConfig)
    angle: AngleConfig = field(default_factory=AngleConfig)
    kinematics: KinematicsConfig = field(default_factory=KinematicsConfig)
    models: ModelsConfig = field(default_factory=ModelsConfig)
    fit: FitConfig = field(default_factory=FitConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    batch: BatchConfig = field(default_factory=BatchConfig)
    discover: DiscoverConfig = field(default_factory=DiscoverConfig)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict (tuples become lists) for JSON provenance."""
        out: dict[str, dict[str, Any]] = {}
        for f in fields(self):
            section = dataclasses.asdict(getattr(self, f.name))
            out[f.name] = {k: list(v) if isinstance(v, tuple) else v for k, v in section.items()}
        return out

    def sections(self, *names: str) -> dict[str, dict[str, Any]]:
        """The named sections only: what a stage records as the config it depends on."""
        full = self.to_dict()
        return {n: full[n] for n in names}

    def replace(self, section: str, **values: Any) -> "Config":
        """A copy with some values of one section changed (CLI flags over the file)."""
        current = getattr(self, section)
        new_section = _coerce_section(type(current), {**dataclasses.asdict(current), **values}, "<flags>", section)
        return dataclasses.replace(self, **{section: new_section})


Check = tuple[Callable[[Any], bool], str]  # (value is valid, what a valid value is)


def _gt(lo: float) -> Check:
    return (lambda v: v > lo), f"must be > {lo:g}"


def _ge(lo: float) -> Check:
    return (lambda v: v >= lo), f"must be >= {lo:g}"


def _within(lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False) -> Check:
    def ok(v: float) -> bool:
        return (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    return ok, f"must be within {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _one_of(choices: tuple[str, ...]) -> Check:
    return (lambda v: v in choices), f"must be one of {', '.join(choices)}"


def _each(check: Check, what: str) -> Check:
    return (lambda v: all(check[0](x) for x in v)), f"must hold {what}"


def _sizes(*sizes: int, what: str) -> Check:
    return (lambda v: len(v) in sizes), f"must be {what}"


_NAME: Check = (lambda v: bool(v.strip())), "must not be empty"
_MARKER_COLOUR: Check = ((lambda v: v in RENDER_MARKER_COLOURS or re.fullmatch(r"#[0-9a-fA-F]{6}", v) is not None),
                         f"must be one of {', '.join(RENDER_MARKER_COLOURS)} or #RRGGBB")
_NAMES: Check = _each(_NAME, "non-empty names")

# Ranges and choices of the values, checked when a config is loaded (before any stage runs).
# Floats must also be finite. Names of models and effects are checked by their registries,
# the marker colour by pendtrack.track.colour, the Dask address by pendtrack.batch.executor,
# and [render] by pendtrack.render.pipeline.check_render_config (with its cross-key rules; the
# field-condition keys of [render] are also checked here, at load time).
CHECKS: dict[str, tuple[Check, ...]] = {
    "lens.projection": (_one_of(LENS_PROJECTIONS),),
    "lens.fov_deg": (_within(0, 360, lo_open=True, hi_open=True),),
    "lens.fixed_pixels": (_within(0, 1, lo_open=True),),
    "video.fps": (_ge(0),),
    "video.start": (_ge(0),),
    "video.end": (_ge(0),),
    "track.roi": (_sizes(0, 4, what="[] or [x, y, w, h]"), _each(_ge(0), "pixels >= 0")),
    "track.search_margin_px": (_gt(0),),
    "track.min_score": (_within(0, 1),),
    "track.evolution_rate": (_within(0, 1),),
    "track.quick_margin_px": (_gt(0),),
    "track.refine": (_one_of(TRACK_REFINE),),
    "track.max_coast_frames": (_ge(0),),
    "track.min_contrast_ratio": (_within(0, 1, lo_open=True),),
    "track.acquire_step_s": (_gt(0),),
    "track.acquire_window_s": (_ge(0),),
    "track.max_drift_px": (_gt(0),),
    "track.hole_share": (_within(0, 2),),
    "angle.axle": (_sizes(0, 2, what="[] or [x, y]"),),
    "angle.rest_seconds": (_gt(0),),
    "angle.rest_omega_max": (_gt(0),),
    "angle.lens_check": (_one_of(LENS_CHECK_MODES),),
    "angle.lens_ratio": (_gt(1),),
    "kinematics.savgol_window_s": (_gt(0),),
    "kinematics.savgol_order": (_ge(1),),
    "kinematics.max_gap_s": (_ge(0),),
    "kinematics.min_segment_s": (_ge(0),),
    "models.memory_s": (_gt(0),),
    "models.max_step_s": (_gt(0),),
    "fit.models": (_NAMES,),
    "fit.cost": (_one_of(FIT_COSTS),),
    "fit.offset": (_one_of(FIT_OFFSETS),),
    "fit.jacobian": (_one_of(FIT_JACOBIANS),),
    "fit.substep_phase": (_ge(0),),
    "fit.steer_phase": (_ge(0),),
    "fit.rung_phase": (_ge(0),),
    "fit.coordinates": (_one_of(FIT_COORDINATES),),
    "fit.n_starts": (_ge(1),),
    "fit.accept_ratio": (_ge(1),),
    "fit.start_spread": (_ge(0),),
    "fit.omega0_spread": (_ge(0),),
    "fit.seed": (_ge(0),),
    "fit.bootstrap": (_ge(0),),
    "fit.start_budget": (_ge(1),),
    "fit.joint_starts": (_ge(0),),
    "fit.ladder_growth": (_gt(1),),
    "fit.ladder_growth_memory": (_gt(1),),
    "fit.hopeless_ratio": (_ge(0),),
    "fit.hopeless_ratio_memory": (_ge(0),),
    "fit.merge_tol": (_ge(0),),
    "fit.workers": (_ge(0),),
    "fit.slow_motion_px": (_ge(0),),
    "batch.scheduler": (_NAME,),
    "batch.workers": (_ge(0),),
    "batch.threads_per_worker": (_ge(1),),
    "batch.inner_workers": (_ge(0),),
    "batch.extensions": (_each(((lambda v: len(v) > 1 and v.startswith(".")), ""), "suffixes with the dot (.mp4)"),),
    "batch.omega0_models": (_NAMES,),
    "render.marker_color": (_MARKER_COLOUR,),
    "render.marker_shape": (_one_of(RENDER_MARKER_SHAPES),),
    "render.rig": (_one_of(RENDER_RIGS),),
    "render.sticker_color": (((lambda v: v == "" or _MARKER_COLOUR[0](v)),
                              f"must be '' (none), {', '.join(RENDER_MARKER_COLOURS)} or #RRGGBB"),),
    "render.sticker_radius_m": (_gt(0),),
    "render.hand_release_s": (_ge(0),),
    "render.camera_roll_deg": (_within(-45, 45),),
    "discover.baseline": (_NAME,),
    "discover.effects": (_NAMES,),
    "discover.train_fraction": (_within(0, 1, lo_open=True, hi_open=True),),
    "discover.heldout_z_min": (_ge(0),),
    "discover.heldout_min_gain": (_ge(0),),
    "discover.cv_blocks": (_ge(2),),
    "discover.max_effects": (_ge(0),),
    "discover.measurement": (_NAMES,),
    "discover.max_combination": (_within(1, 3),),
    "discover.combination_pool": (_ge(2),),
    "discover.n_starts_baseline": (_ge(1),),
    "discover.n_starts": (_ge(0),),
    "discover.workers": (_ge(0),),
    "discover.analysis_rate_hz": (_ge(0),),
    "discover.n_replicas": (_ge(0),),
    "discover.near_turning_fraction": (_within(0, 1, lo_open=True),),
    "discover.seed": (_ge(0),),
}


def _check_value(value: Any, raw: Any, source: str, key: str) -> None:
    """Raise :class:`ConfigError` naming ``key`` when ``value`` breaks a rule of :data:`CHECKS`."""
    items = value if isinstance(value, tuple) else (value,)
    if any(isinstance(x, float) and not math.isfinite(x) for x in items):
        raise ConfigError(f"'{key}' must be finite, got {raw!r}", path=source)
    for ok, text in CHECKS.get(key, ()):
        if not ok(value):
            raise ConfigError(f"'{key}' {text}, got {raw!r}", path=source)


def _coerce_value(value: Any, hint: Any, source: str, key: str) -> Any:
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"'{key}' must be a number, got {value!r}", path=source)
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"'{key}' must be an integer, got {value!r}", path=source)
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"'{key}' must be true or false, got {value!r}", path=source)
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"'{key}' must be a string, got {value!r}", path=source)
        return value
    origin = getattr(hint, "__origin__", None)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"'{key}' must be a list, got {value!r}", path=source)
        item_hint = hint.__args__[0]
        return tuple(_coerce_value(v, item_hint, source, key) for v in value)
    raise TypeError(f"unsupported config type {hint!r} for {key}")  # programming error


#: Settings that no longer exist, with what to use instead (a one-line error names it).
REMOVED_KEYS = {
    "fit.time_budget_s": "a fit's work is set by n_starts and start_budget, never by seconds (the same input gives "
                         "the same fit on any machine); remove the key",
    "fit.time_reserve": "a fit has no time budget any more; remove the key",
}


def _coerce_section(cls: type, values: dict[str, Any], source: str, section: str) -> Any:
    hints = get_type_hints(cls)
    known = {f.name for f in fields(cls)}
    for key in values:
        if f"{section}.{key}" in REMOVED_KEYS:
            raise ConfigError(f"'{section}.{key}' is no longer a setting: {REMOVED_KEYS[f'{section}.{key}']}",
                              path=source)
        if key not in known:
            raise ConfigError(f"unknown key '{section}.{key}'", path=source)
    coerced = {k: _coerce_value(v, hints[k], source, f"{section}.{k}") for k, v in values.items()}
    for k, v in coerced.items():
        _check_value(v, values[k], source, f"{section}.{k}")
    out = cls(**coerced)
    if isinstance(out, VideoConfig) and out.end and out.end <= out.start:  # the one rule across two keys
        raise ConfigError(f"'{section}.end' must be 0 (to the last frame) or later than "
                          f"'{section}.start' = {out.start!r}, got {out.end!r}", path=source)
    return out


def config_from_dict(data: dict[str, Any], *, source: str = "<dict>") -> Config:
    """Build a :class:`Config` from nested dicts holding only the keys that change."""
    hints = get_type_hints(Config)
    known = {f.name for f in fields(Config)}
    sections: dict[str, Any] = {}
    for name, values in data.items():
        if name not in known:
            raise ConfigError(f"unknown section '[{name}]'", path=source)
        if not isinstance(values, dict):
            raise ConfigError(f"'{name}' must be a table", path=source)
        sections[name] = _coerce_section(hints[name], values, source, name)
    return Config(**sections)


def load_config(path: str | Path | None = None) -> Config:
    """Load a TOML config file over the defaults; ``None`` gives the defaults."""
    if path is None:
        return Config()
    path = Path(path)
    if not path.is_file():
        raise ConfigError("config file not found", path=path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"not valid TOML ({exc})", path=path) from None
    return config_from_dict(data, source=str(path))
