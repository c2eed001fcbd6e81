"""Robust circle fit: the pendulum's axle from the marker's path.

An algebraic fit (Kasa, or Pratt's gradient-weighted one, which is unbiased on short arcs)
starts a geometric least-squares refinement of the radial residuals
``hypot(x - xc, y - yc) - r`` with a robust loss (``soft_l1``), so a few bad points do
not pull the centre. Units are those of the points (px).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, ndimage, optimize


@dataclass(frozen=True)
class CircleFit:
    """A fitted circle.

    Attributes
    ----------
    xc, yc : float
        Centre [px].
    radius : float
        [px].
    rms : float
        Root mean square of the radial residuals of all points [px].
    mad : float
        Median absolute radial residual [px].
    n : int
        Number of points.
    arc_span : float
        Angle covered by the points as seen from the centre [rad], 2 pi for a full circle.
    """

    xc: float
    yc: float
    radius: float
    rms: float
    mad: float
    n: int
    arc_span: float

    def to_dict(self) -> dict[str, float | int]:
        return {"xc": self.xc, "yc": self.yc, "radius": self.radius, "rms_px": self.rms, "mad_px": self.mad,
                "n": self.n, "arc_span_deg": float(np.degrees(self.arc_span))}


def _check(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError("x and y must have the same length")
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if x.size < 3:
        raise ValueError("a circle needs at least 3 finite points")
    return x, y


def fit_circle_kasa(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Kasa's algebraic fit: least squares of ``x^2 + y^2 + D x + E y + F``; (xc, yc, r)."""
    x, y = _check(x, y)
    mx, my = x.mean(), y.mean()
    u, v = x - mx, y - my
    a = np.column_stack([u, v, np.ones_like(u)])
    (d, e, f), *_ = np.linalg.lstsq(a, -(u * u + v * v), rcond=None)
    xc, yc = -d / 2.0, -e / 2.0
    return float(xc + mx), float(yc + my), float(np.sqrt(max(xc * xc + yc * yc - f, 0.0)))


def fit_circle_pratt(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Pratt's algebraic fit (generalised eigenproblem); (xc, yc, r).

    Minimises ``sum (A z + B x + C y + D)^2`` with ``z = x^2 + y^2`` subject to
    ``B^2 + C^2 - 4 A D = 1``.
    """
    x, y = _check(x, y)
    mx, my = x.mean(), y.mean()
    u, v = x - mx, y - my
    s = np.sqrt(np.mean(u * u + v * v)) or 1.0  # scale for conditioning
    u, v = u / s, v / s
    z = u * u + v * v
    zm = np.column_stack([z, u, v, np.ones_like(u)])
    m = zm.T @ zm / u.size
    b = np.array([[0.0, 0, 0, -2], [0, 1, 0, 0], [0, 0, 1, 0], [-2, 0, 0, 0]])
    w, vecs = linalg.eig(m, b)
    w = np.real(w)
    good = np.isfinite(w) & (w >= -1e-12)
    if not good.any():
        return fit_circle_kasa(x, y)
    k = np.flatnonzero(good)[np.argmin(w[good])]
    a_, b_, c_, d_ = np.real(vecs[:, k])
    if abs(a_) < 1e-14:  # a straight line
        return fit_circle_kasa(x, y)
    xc, yc = -b_ / (2 * a_), -c_ / (2 * a_)
    r = np.sqrt(max(b_ * b_ + c_ * c_ - 4 * a_ * d_, 0.0)) / (2 * abs(a_))
    return float(xc * s + mx), float(yc * s + my), float(r * s)


def arc_span(x: np.ndarray, y: np.ndarray, xc: float, yc: float) -> float:
    """Angle [rad] covered by the points around ``(xc, yc)``: 2 pi minus the largest empty gap."""
    ang = np.sort(np.arctan2(np.asarray(y) - yc, np.asarray(x) - xc))
    if ang.size < 2:
        return 0.0
    gaps = np.diff(np.concatenate([ang, [ang[0] + 2 * np.pi]]))
    return float(2 * np.pi - gaps.max())


def fit_circle(x: np.ndarray, y: np.ndarray, *, loss: str = "soft_l1", f_scale: float = 1.0) -> CircleFit:
    """Robust geometric circle fit started from Pratt's algebraic fit.

    Parameters
    ----------
    x, y : array_like
        Points [px]; non-finite ones are ignored.
    loss : str
        ``scipy.optimize.least_squares`` loss on the radial residuals.
    f_scale : float
        Residual size [px] beyond which the robust loss flattens.

    Returns
    -------
    CircleFit
    """
    x, y = _check(x, y)
    x0 = np.array(fit_circle_pratt(x, y))

    def resid(p: np.ndarray) -> np.ndarray:
        return np.hypot(x - p[0], y - p[1]) - p[2]

    def jac(p: np.ndarray) -> np.ndarray:
        d = np.hypot(x - p[0], y - p[1])
        d = np.where(d > 0, d, 1.0)
        return np.column_stack([-(x - p[0]) / d, -(y - p[1]) / d, -np.ones_like(d)])

    sol = optimize.least_squares(resid, x0, jac=jac, loss=loss, f_scale=f_scale, method="trf",
                                 x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    xc, yc, r = (float(a) for a in sol.x)
    if r < 0:
        r = -r
    res = np.hypot(x - xc, y - yc) - r
    return CircleFit(xc=xc, yc=yc, radius=r, rms=float(np.sqrt(np.mean(res * res))),
                     mad=float(np.median(np.abs(res))), n=int(x.size), arc_span=arc_span(x, y, xc, yc))


#: A point is off its circle when its radius differs from the running median of its neighbours' by more than this
#: many robust standard deviations of that difference (8: a tracking error from Gaussian noise never gets there) ...
OFF_CIRCLE_SIGMAS = 8.0
#: ... and by more than this [px] (below it a look-alike cannot be told from the marker's own noise)
OFF_CIRCLE_FLOOR_PX = 1.0
#: The running median spans this many points: a look-alike taken for up to 5 consecutive frames leaves it on the
#: marker's radius, while a lens's smooth change of the radius over a swing is followed (a median of a monotone
#: stretch is its middle point)
OFF_CIRCLE_WINDOW = 11


def off_circle(x: np.ndarray, y: np.ndarray, centre: tuple[float, float], *, sigmas: float = OFF_CIRCLE_SIGMAS,
               floor: float = OFF_CIRCLE_FLOOR_PX, window: int = OFF_CIRCLE_WINDOW) -> tuple[np.ndarray, float]:
    """The points of a path that leave the circle about ``centre`` for a few frames: a Hampel filter on the radius.

    A rigid pendulum's marker keeps its distance from the axle; a point that jumps off that distance and back is
    something else the tracker took for the marker (the pivot, a look-alike), however well its template scored.
    The radius is compared with the running median of :data:`OFF_CIRCLE_WINDOW` points, so the smooth change of
    the radius over a swing that a residual lens distortion or a wobbling bob leaves is not mistaken for one.

    Parameters
    ----------
    x, y : ndarray
        The points in time order [px], all finite.
    centre : (float, float)
        The axle [px].
    sigmas, floor, window
        The threshold: more than ``sigmas`` robust standard deviations (1.4826 times the median absolute
        difference from the running median) and more than ``floor`` [px]; the running median's length [points].

    Returns
    -------
    off : ndarray, bool
        True where the point is off its circle.
    threshold : float
        The difference from the running median beyond which a point is off [px].
    """
    r = np.hypot(np.asarray(x, float) - centre[0], np.asarray(y, float) - centre[1])
    if r.size < window:
        return np.zeros(r.size, bool), np.inf
    dev = np.abs(r - ndimage.median_filter(r, size=window, mode="nearest"))
    threshold = max(sigmas * 1.4826 * float(np.median(dev)), floor)
    return dev > threshold, threshold


#: At most this many blocks in the jackknife of :func:`circle_uncertainty` (9 degrees of freedom for its variance).
JACKKNIFE_BLOCKS = 10
#: Each block spans at least this many correlation lengths of the radial residuals, so the blocks' errors are nearly
#: independent (a compressed video's tracking errors: lag-1 correlation 0.8, first negative near lag 15-20 at 60 fps).
BLOCK_CORRELATION_LENGTHS = 4
#: ... and holds at least this many points (a circle fit to the rest must stay as well posed as to the whole).
MIN_BLOCK_POINTS = 10


def correlation_length(r: np.ndarray) -> int:
    """The first lag (>= 1) at which the sample autocorrelation of ``r`` is <= 0 [samples]; ``len(r)`` if none."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    n = r.size
    if n < 2 or not np.any(r):
        return 1
    spec = np.fft.rfft(r, 2 * n)
    acf = np.fft.irfft(spec * np.conj(spec))[:n]
    below = np.flatnonzero(acf[1:] <= 0.0)
    return int(below[0]) + 1 if below.size else n


def _block_jackknife(x: np.ndarray, y: np.ndarray, blocks: int) -> np.ndarray:
    """Delete-one-block jackknife standard errors of ``(xc, yc, r)`` over ``blocks`` consecutive blocks [px]."""
    edges = np.linspace(0, x.size, blocks + 1).round().astype(int)
    est = np.empty((blocks, 3))
    for k in range(blocks):
        keep = np.ones(x.size, bool)
        keep[edges[k]:edges[k + 1]] = False
        f = fit_circle(x[keep], y[keep])
        est[k] = (f.xc, f.yc, f.radius)
    return np.sqrt((blocks - 1) / blocks * np.sum((est - est.mean(axis=0)) ** 2, axis=0))


def circle_uncertainty(x: np.ndarray, y: np.ndarray, fit: CircleFit) -> tuple[float, float, float]:
    """Standard uncertainties of a circle fit's centre and radius [px]: (sigma_xc, sigma_yc, sigma_r).

    The larger of two estimates per parameter: the formal one (Gauss-Newton covariance at
    the fit, residual scale from the median absolute residual), which assumes independent
    errors, and a delete-one-block jackknife over consecutive blocks of the points (in their
    order: for a track, time), which sees what the formal one cannot -- tracking errors
    correlated from frame to frame (a compressed video's: at 640x360 they move the axle by
    2-3 times the formal estimate), a wobbling bob, a residual lens distortion. Each block
    spans at least :data:`BLOCK_CORRELATION_LENGTHS` correlation lengths of the radial
    residuals (:func:`correlation_length`), and there are at most :data:`JACKKNIFE_BLOCKS`;
    too few points for two blocks leave the formal estimate alone.

    Parameters
    ----------
    x, y : array_like
        The points the circle was fitted to [px], in time order.
    fit : CircleFit

    Returns
    -------
    (float, float, float)
        [px]; inf when the points cannot pin the circle down (a straight arc).
    """
    x, y = _check(x, y)
    d = np.hypot(x - fit.xc, y - fit.yc)
    d = np.where(d > 0, d, 1.0)
    j = np.column_stack([-(x - fit.xc) / d, -(y - fit.yc) / d, -np.ones_like(d)])
    sigma = 1.4826 * fit.mad
    try:
        formal = np.sqrt(np.clip(np.diag(np.linalg.inv(j.T @ j)), 0, None)) * sigma
    except np.linalg.LinAlgError:
        return float("inf"), float("inf"), float("inf")
    block = max(BLOCK_CORRELATION_LENGTHS * correlation_length(d - fit.radius), MIN_BLOCK_POINTS)
    blocks = min(JACKKNIFE_BLOCKS, x.size // block)
    jack = _block_jackknife(x, y, blocks) if blocks >= 2 else np.zeros(3)
    out = np.maximum(formal, jack)
    return float(out[0]), float(out[1]), float(out[2])
