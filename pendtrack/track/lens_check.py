"""Is the configured lens the footage's? The track's circle under several lens corrections.

The marker swings on a circle about the axle, and a circle in the pendulum's plane is a
circle in a rectilinear (lens-corrected) image of it. So the raw marker positions are
corrected under each lens hypothesis and a robust circle is fitted to each; the right lens
leaves only the tracking noise, a wrong one adds a swing-synchronous radial residual.

Hypotheses
----------
* the configured lens;
* ``none`` (a normal, rectilinear lens; skipped when it is the configured one);
* the paper's fisheye (:class:`pendtrack.config.LensConfig` defaults, equisolid 120 deg),
  when the configured lens differs from it;
* a fitted field of view: the configured projection (equisolid when the configured one is
  ``none``) with the diagonal field of view that fits the circle best, searched over
  ``[FOV_MIN_DEG, FOV_MAX_DEG]`` (a field of view towards 0 tends to ``none``; beyond 180 deg
  diagonal a lens no longer fills the frame, so no such lens is proposed).

The fixed-pixel fraction only scales the corrected image about its centre, which keeps
circles circles: it cannot be checked and is not varied.

The rule
--------
Each hypothesis' residual is the trimmed RMS radial residual (points within 5 robust
standard deviations) divided by its circle's radius, so that corrections of different
scale compare. Then:

1. **undecided** when fewer than ``MIN_POINTS`` ok points, the points span less than
   ``MIN_EXTENT_PX`` (a point that hardly moves: no circle to judge) or the arc spans less
   than ``MIN_ARC_DEG`` degrees;
2. **undecided** when the geometry cannot tell a normal lens from the fisheye: the arc
   fitted under the fisheye (the configured one, or the paper's) is mapped to raw pixels
   and corrected as a normal lens, and the reverse; if the systematic residual this adds
   would raise the noise-level residual (the best hypothesis') by less than the factor
   ``ratio``, no lens can be told from another here. This is the README's known limit: a
   circle centred on the optical axis stays a circle under any radial correction; a short
   arc is bent into a circle of another radius;
3. **undecided** when no hypothesis leaves the track a circle to tracking precision (the
   best residual is above ``MAX_BEST_RMS_PX``, or more than ``MAX_OUTLIER_SHARE`` of the
   points are off its circle): a track that jumps or wobbles is no circle
   under any lens, and whichever lens happens to fit its noise best is no evidence;
4. the **best** hypothesis is the one with the smallest residual; those within
   ``BEST_TOLERANCE`` of it count as equally good, and the first of configured, ``none``,
   paper's fisheye, fitted field of view is taken (no fitted value is preferred to a
   simpler one that fits as well);
5. **mismatch** when the configured lens' residual is at least ``ratio`` (2 by default)
   times the best one's; otherwise **consistent**.

Each hypothesis also records how far theta under it departs from theta under the configured
lens (each with its own fitted axle; RMS after removing the mean) [mrad]: what is at stake.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from pendtrack.lens.fisheye import Fisheye
from pendtrack.track.circle import CircleFit, fit_circle

MIN_POINTS = 30  # fewer ok points: undecided
MIN_ARC_DEG = 60.0  # a shorter arc: undecided (a circle of another radius absorbs the distortion)
MAX_POINTS = 1500  # the check thins longer tracks evenly (its cost, not its outcome)
BEST_TOLERANCE = 1.1  # residuals within this factor of the smallest count as equally good
FOV_MIN_DEG, FOV_MAX_DEG = 10.0, 180.0  # fitted field of view search range [deg]: plausible full-frame lenses
MIN_EXTENT_PX = 20.0  # points spanning less (bounding-box diagonal) [px]: undecided, no circle to judge
# The best lens must leave the track a circle to this trimmed RMS [px]: subpixel tracking plus motion blur and a
# wobbling bob stay well below it (rendered tracks: 0.05-0.5 px), a lens off by tens of degrees or a track
# that jumps between objects is far above it.
MAX_BEST_RMS_PX = 2.0
MAX_OUTLIER_SHARE = 0.1  # ... with at most this share of the points off it (frames on another object)
PAPER_PROJECTION, PAPER_FOV_DEG = "equisolid", 120.0  # the paper's lens (LensConfig defaults)
TRIM_SIGMAS = 5.0  # residuals beyond this many robust standard deviations are outliers (lost frames)


@dataclass(frozen=True)
class LensHypothesis:
    """One lens correction of the track and its circle.

    Attributes
    ----------
    name : str
        ``configured``, ``none``, ``paper`` or ``fitted_fov``.
    projection : str
    fov_deg : float
        Input diagonal field of view [deg] (meaningless for ``none``).
    rms_px : float
        Trimmed RMS radial residual of the circle [px of this correction].
    rms_rel : float
        ``rms_px`` over the circle's radius [1].
    radius_px : float
        The circle's radius [px of this correction].
    arc_span_deg : float
        Angle covered by the points, seen from the circle's centre [deg].
    theta_change_mrad : float
        RMS of theta under this lens minus theta under the configured one, mean removed [mrad].
    """

    name: str
    projection: str
    fov_deg: float
    rms_px: float
    rms_rel: float
    radius_px: float
    arc_span_deg: float
    theta_change_mrad: float

    @property
    def label(self) -> str:
        return lens_label(self.projection, self.fov_deg)

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "label": self.label, "projection": self.projection, "fov_deg": self.fov_deg,
                "rms_px": self.rms_px, "rms_rel": self.rms_rel, "radius_px": self.radius_px,
                "arc_span_deg": self.arc_span_deg, "theta_change_mrad": self.theta_change_mrad}


@dataclass(frozen=True)
class LensCheck:
    """The outcome of :func:`check_lens`.

    Attributes
    ----------
    verdict : str
        ``consistent``, ``mismatch`` or ``undecided``.
    reason : str
        One sentence saying why.
    configured : str
        Label of the configured lens.
    best : str
        Name of the best hypothesis (``""`` when undecided before fitting).
    ratio : float
        Configured residual over the best one [1] (NaN when not computed).
    threshold : float
        The ratio that makes a mismatch.
    separation : float
        Factor by which a normal lens instead of the fisheye (or the reverse) would raise
        the noise-level residual on this arc [1] (NaN when not computed).
    hypotheses : tuple of LensHypothesis
    suggestion : dict or None
        ``{"projection", "fov_deg"}`` of the best lens when it is not the configured one.
    """

    verdict: str
    reason: str
    configured: str
    best: str
    ratio: float
    threshold: float
    separation: float
    hypotheses: tuple[LensHypothesis, ...]
    suggestion: dict[str, object] | None

    def hypothesis(self, name: str) -> LensHypothesis | None:
        return next((h for h in self.hypotheses if h.name == name), None)

    def to_dict(self) -> dict[str, object]:
        def num(a: float) -> float | None:
            return float(a) if np.isfinite(a) else None

        return {"verdict": self.verdict, "reason": self.reason, "configured": self.configured, "best": self.best,
                "ratio": num(self.ratio), "threshold": self.threshold, "separation": num(self.separation),
                "hypotheses": [h.to_dict() for h in self.hypotheses], "suggestion": self.suggestion}


def lens_label(projection: str, fov_deg: float) -> str:
    """``"none (no correction)"`` or e.g. ``"equisolid 120 deg"``."""
    return "none (no correction)" if projection == "none" else f"{projection} {fov_deg:.4g} deg"


def suggestion_flags(suggestion: dict[str, object]) -> str:
    """The ``--projection``/``--fov`` flags that select a suggested lens."""
    if suggestion["projection"] == "none":
        return "--projection none"
    return f"--projection {suggestion['projection']} --fov {float(suggestion['fov_deg']):.0f}"  # type: ignore[arg-type]


def _inliers(x: np.ndarray, y: np.ndarray, c: CircleFit) -> tuple[np.ndarray, np.ndarray]:
    """Radial residuals [px] and the mask of those within ``TRIM_SIGMAS`` robust standard deviations."""
    r = np.hypot(x - c.xc, y - c.yc) - c.radius
    med = float(np.median(r))
    s = 1.4826 * float(np.median(np.abs(r - med)))
    return r, (np.abs(r - med) <= TRIM_SIGMAS * s if s > 0 else np.ones(r.size, bool))


def _trimmed_rms(x: np.ndarray, y: np.ndarray, c: CircleFit) -> float:
    r, keep = _inliers(x, y, c)
    return float(np.sqrt(np.mean(r[keep] ** 2)))


def _fit(fe: Fisheye, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, CircleFit, float]:
    x, y = fe.undistort_points(u, v)
    c = fit_circle(x, y)
    return x, y, c, _trimmed_rms(x, y, c) / c.radius if c.radius > 0 else np.inf


def _fisheye(width: int, height: int, projection: str, fov_deg: float, fixed_pixels: float) -> Fisheye:
    return Fisheye(width=width, height=height, projection=projection, fov_deg=fov_deg, fixed_pixels=fixed_pixels)


def _systematic(true: Fisheye, other: Fisheye, x: np.ndarray, y: np.ndarray, c: CircleFit) -> float:
    """Relative circle residual ``other`` would show on noise-free points of ``true``'s circle ``c``."""
    ang = np.arctan2(y - c.yc, x - c.xc)
    u, v = true.distort_points(c.xc + c.radius * np.cos(ang), c.yc + c.radius * np.sin(ang))
    return _fit(other, u, v)[3]


def _best_fov(u: np.ndarray, v: np.ndarray, *, width: int, height: int, projection: str,
              fixed_pixels: float) -> float:
    """Diagonal field of view [deg] of ``projection`` under which the track is most circular."""
    hi = min(FOV_MAX_DEG, 179.0) if projection == "orthographic" else FOV_MAX_DEG

    def cost(fov: float) -> float:
        return _fit(_fisheye(width, height, projection, fov, fixed_pixels), u, v)[3]

    grid = np.linspace(FOV_MIN_DEG, hi, 15)
    costs = np.array([cost(f) for f in grid])
    k = int(np.argmin(costs))
    lo_b, hi_b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    sol = minimize_scalar(cost, bounds=(lo_b, hi_b), method="bounded", options={"xatol": 0.5})
    return float(sol.x) if sol.fun <= costs[k] else float(grid[k])


def _theta(x: np.ndarray, y: np.ndarray, c: CircleFit, order: np.ndarray) -> np.ndarray:
    th = np.unwrap(np.arctan2(x[order] - c.xc, y[order] - c.yc))
    return th - th.mean()


def check_lens(u: np.ndarray, v: np.ndarray, *, width: int, height: int, projection: str, fov_deg: float,
               fixed_pixels: float, ratio: float = 2.0) -> LensCheck:
    """Compare the configured lens with the alternatives on a marker track (see the module docstring).

    Parameters
    ----------
    u, v : ndarray
        Raw (uncorrected) marker centres of the ok frames, in time order [px]; non-finite
        ones are ignored.
    width, height : int
        Frame size [px].
    projection, fov_deg, fixed_pixels
        The configured lens (:class:`pendtrack.config.LensConfig`).
    ratio : float
        Residual ratio (configured over best) that makes a mismatch, > 1.

    Returns
    -------
    LensCheck
    """
    configured = lens_label(projection, fov_deg)
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    keep = np.isfinite(u) & np.isfinite(v)
    u, v = u[keep], v[keep]
    if u.size > MAX_POINTS:
        idx = np.linspace(0, u.size - 1, MAX_POINTS).round().astype(int)
        u, v = u[idx], v[idx]

    def undecided(reason: str, hyps: tuple[LensHypothesis, ...] = (), separation: float = np.nan) -> LensCheck:
        return LensCheck("undecided", reason, configured, "", np.nan, ratio, separation, hyps, None)

    if u.size < MIN_POINTS:
        return undecided(f"only {u.size} ok points: at least {MIN_POINTS} are needed to compare lenses")
    extent = float(np.hypot(np.ptp(u), np.ptp(v)))
    if extent < MIN_EXTENT_PX:
        return undecided(f"the points span {extent:.1f} px: at least {MIN_EXTENT_PX:g} px of swing are needed to "
                         f"compare lenses")
    fes: dict[str, Fisheye] = {"configured": _fisheye(width, height, projection, fov_deg, fixed_pixels)}
    if projection != "none":
        fes["none"] = _fisheye(width, height, "none", fov_deg, fixed_pixels)
    if (projection, fov_deg) != (PAPER_PROJECTION, PAPER_FOV_DEG):
        fes["paper"] = _fisheye(width, height, PAPER_PROJECTION, PAPER_FOV_DEG, fixed_pixels)
    fits = {name: _fit(fe, u, v) for name, fe in fes.items()}
    order = np.arange(u.size)

    def hypotheses() -> tuple[LensHypothesis, ...]:
        x_c, y_c, c_c, _ = fits["configured"]
        theta_c = _theta(x_c, y_c, c_c, order)
        hyps = []
        for name, fe in fes.items():
            x, y, c, rel = fits[name]
            d = _theta(x, y, c, order) - theta_c
            hyps.append(LensHypothesis(name=name, projection=fe.projection, fov_deg=float(fe.fov_deg),
                                       rms_px=float(rel * c.radius), rms_rel=float(rel), radius_px=float(c.radius),
                                       arc_span_deg=float(np.degrees(c.arc_span)),
                                       theta_change_mrad=float(1e3 * np.sqrt(np.mean(d * d)))))
        return tuple(hyps)

    span = float(np.degrees(fits["configured"][2].arc_span))
    if span < MIN_ARC_DEG:
        # no verdict, but what each lens would make of theta: what the unchecked default lens puts at stake
        return undecided(f"the arc spans {span:.0f} deg: at least {MIN_ARC_DEG:.0f} deg are needed to compare lenses",
                         hypotheses())
    fit_projection = projection if projection != "none" else PAPER_PROJECTION
    fov_fit = _best_fov(u, v, width=width, height=height, projection=fit_projection, fixed_pixels=fixed_pixels)
    fes["fitted_fov"] = _fisheye(width, height, fit_projection, fov_fit, fixed_pixels)
    fits["fitted_fov"] = _fit(fes["fitted_fov"], u, v)
    hyps_t = hypotheses()
    noise = min(h.rms_rel for h in hyps_t)
    fish = "configured" if projection != "none" else "paper"
    normal = "none" if projection != "none" else "configured"
    xs, ys, cs, _ = fits[fish]
    xn, yn, cn, _ = fits[normal]
    sys_rel = max(_systematic(fes[fish], fes[normal], xs, ys, cs), _systematic(fes[normal], fes[fish], xn, yn, cn))
    separation = float(np.sqrt(1.0 + (sys_rel / noise) ** 2)) if noise > 0 else np.inf
    if separation < ratio:
        return undecided(f"the geometry cannot tell the lenses apart: on this arc a normal lens instead of the "
                         f"fisheye would raise the circle residual only {separation:.2f}x (a mismatch needs "
                         f"{ratio:g}x; the axle is near the optical axis, or the arc is short)", hyps_t, separation)
    best = next(h for h in hyps_t if h.rms_rel <= BEST_TOLERANCE * noise)
    outliers = 1.0 - float(np.mean(_inliers(*fits[best.name][:3])[1]))
    if best.rms_px > MAX_BEST_RMS_PX or outliers > MAX_OUTLIER_SHARE:
        return undecided(f"no lens makes the track a circle (the best, {best.label}, leaves {best.rms_px:.1f} px "
                         f"rms and {100 * outliers:.0f} % of the points off it; a lens can be judged below "
                         f"{MAX_BEST_RMS_PX:g} px and {100 * MAX_OUTLIER_SHARE:.0f} %): the track is not a clean arc",
                         hyps_t, separation)
    conf = hyps_t[0]
    r = conf.rms_rel / best.rms_rel if best.rms_rel > 0 else 1.0
    if best.name == "configured" or r < ratio:
        return LensCheck("consistent", f"the configured lens fits the circle within {r:.2f}x of the best "
                         f"({best.label}; a mismatch needs {ratio:g}x)", configured, best.name, r, ratio,
                         separation, hyps_t, None)
    suggestion = {"projection": best.projection, "fov_deg": round(best.fov_deg, 1)}
    reason = (f"the track fits a circle {r:.1f}x better with {best.label} ({best.rms_px:.2f} px) than with the "
              f"configured {configured} ({conf.rms_px:.2f} px): theta under the configured lens differs by "
              f"{best.theta_change_mrad:.0f} mrad rms")
    return LensCheck("mismatch", reason, configured, best.name, r, ratio, separation, hyps_t, suggestion)
