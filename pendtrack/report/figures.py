"""The run report's figures: pure functions from arrays to a :class:`matplotlib.figure.Figure`.

Each function draws one of the paper's figures for one run (the paper's label is given in
the docstring) and knows nothing about files. Units: time in s, angles in rad, angular
velocity in rad/s, angular acceleration in rad/s^2, image coordinates in px (y down).
Model curves are passed as mappings ``model name -> array`` aligned with the data's time.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from pendtrack.kinematics import negative_damping_flags, negative_damping_fraction
from pendtrack.report.style import (
    DATA_COLOR,
    FLAG_COLOR,
    NEGATIVE_FILL,
    model_color,
    new_figure,
    tidy,
)

L_T = "$t$ [s]"
L_THETA = r"$\theta$ [rad]"
L_OMEGA = r"$\omega$ [rad/s]"
L_ALPHA = r"$\alpha$ [rad/s$^2$]"
L_DALPHA = r"$\Delta\alpha=\alpha+\Omega_0^2\sin\theta$ [rad/s$^2$]"


def _finite(*arrays: np.ndarray) -> np.ndarray:
    mask = np.ones(np.asarray(arrays[0]).shape, bool)
    for a in arrays:
        mask &= np.isfinite(np.asarray(a, float))
    return mask


def _thin(n: int, limit: int) -> slice:
    """A stride that keeps at most about ``limit`` of ``n`` points (for dense scatter plots)."""
    return slice(None, None, max(1, int(np.ceil(n / limit))))


def _shade_negative_damping(ax: Axes) -> None:
    """Shade the odd quadrants (Delta alpha * omega > 0) of an (omega, Delta alpha) plot."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    ax.fill_between([0, max(x1, 0)], 0, max(y1, 0), color=NEGATIVE_FILL, zorder=0, linewidth=0)
    ax.fill_between([min(x0, 0), 0], min(y0, 0), 0, color=NEGATIVE_FILL, zorder=0, linewidth=0)
    ax.axhline(0, color="0.5", linewidth=0.7, zorder=1)
    ax.axvline(0, color="0.5", linewidth=0.7, zorder=1)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def track_quality_figure(t: np.ndarray, score: np.ndarray, ok: np.ndarray, *,
                         min_score: float | None = None) -> Figure:
    """Template-match score of every frame, with the flagged (not ok) frames marked.

    Parameters
    ----------
    t : ndarray
        Frame times [s].
    score : ndarray
        Normalised match score [1] in [-1, 1] (NaN where the marker was not searched).
    ok : ndarray of bool
        False for flagged frames.
    min_score : float, optional
        Acceptance threshold drawn as a dashed line.
    """
    t = np.asarray(t, float)
    score = np.asarray(score, float)
    bad = ~np.asarray(ok, bool)
    fig = new_figure(9.0, 3.0)
    ax = tidy(fig.add_subplot())
    ax.plot(t, score, color=DATA_COLOR, linewidth=0.6, label="match score")
    if bad.any():
        y_bad = np.where(np.isfinite(score[bad]), score[bad], np.nanmin(score) if np.isfinite(score).any() else 0.0)
        ax.plot(t[bad], y_bad, "|", color=FLAG_COLOR, markersize=8,
                label=f"flagged frames ({bad.sum()}, {100 * bad.mean():.2f} %)")
    if min_score is not None:
        ax.axhline(min_score, color=FLAG_COLOR, linestyle="--", linewidth=0.9, label=f"threshold {min_score:g}")
    ax.set_xlabel(L_T)
    ax.set_ylabel("match score [1]")
    if t.size:
        ax.set_xlim(t.min(), t.max())
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    return fig


def circle_fit_figure(t: np.ndarray, x: np.ndarray, y: np.ndarray, ok: np.ndarray, *,
                      axle: tuple[float, float] | None, radius: float | None,
                      rms: float | None = None) -> Figure:
    """Marker positions (lens-corrected) with the fitted circle around the axle, and the radial residual.

    Parameters
    ----------
    t : ndarray
        Frame times [s].
    x, y : ndarray
        Corrected marker centre [px], x right, y down.
    ok : ndarray of bool
        Frames used (others drawn in red).
    axle : (float, float) or None
        Fitted (or configured) axle position [px]; None draws the track only.
    radius : float or None
        Fitted circle radius [px]; None uses the median distance to the axle.
    rms : float, optional
        Root-mean-square radial residual reported by the angle stage [px].
    """
    t, x, y = (np.asarray(a, float) for a in (t, x, y))
    ok = np.asarray(ok, bool)
    fig = new_figure(9.0, 3.8)
    gs = fig.add_gridspec(1, 2, width_ratios=(1.0, 1.7))
    ax = tidy(fig.add_subplot(gs[0]))
    stride = _thin(x.size, 6000)
    ax.plot(x[ok][stride], y[ok][stride], ".", color=DATA_COLOR, markersize=1.5, label="tracked (ok)")
    if (~ok).any():
        ax.plot(x[~ok], y[~ok], "x", color=FLAG_COLOR, markersize=4, label="flagged")
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_yaxis()
    ax.set_xlabel("$x$ [px] (corrected)")
    ax.set_ylabel("$y$ [px] (corrected, down)")
    ax2 = tidy(fig.add_subplot(gs[1]))
    if axle is not None:
        dist = np.hypot(x - axle[0], y - axle[1])
        r = float(np.nanmedian(dist[ok])) if radius is None else float(radius)
        phi = np.linspace(0, 2 * np.pi, 361)
        ax.plot(axle[0] + r * np.sin(phi), axle[1] + r * np.cos(phi), "--", color=model_color("classic"),
                linewidth=1.0, label=f"fitted circle, R = {r:.1f} px")
        ax.plot([axle[0]], [axle[1]], "+", color=model_color("classic"), markersize=10, label="axle")
        resid = dist - r
        ax2.plot(t[ok], resid[ok], ".", color=DATA_COLOR, markersize=1.2, label="radial residual")
        if (~ok).any():
            ax2.plot(t[~ok], resid[~ok], "x", color=FLAG_COLOR, markersize=3, label="flagged")
        spread = rms if rms is not None else float(np.sqrt(np.nanmean(resid[ok] ** 2)))
        ax2.axhspan(-spread, spread, color=model_color("classic"), alpha=0.12,
                    label=f"±RMS = {spread:.2f} px")
        finite = resid[ok][np.isfinite(resid[ok])]
        if finite.size:
            lim = max(5 * spread, float(np.percentile(np.abs(finite), 99.5)) * 1.2, 0.5)
            ax2.set_ylim(-lim, lim)
        ax2.set_ylabel("distance to axle − R [px]")
        ax2.legend(loc="upper right", fontsize=8, markerscale=4)
    else:
        ax2.text(0.5, 0.5, "no axle recorded by the angle stage", ha="center", va="center",
                 transform=ax2.transAxes)
    ax2.set_xlabel(L_T)
    ax.legend(loc="center", fontsize=7)
    return fig


def kinematics_figure(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray) -> Figure:
    """Paper's Fig. S1: the three-dimensional kinematic data (theta, omega, alpha), coloured by time.

    A 3-D trajectory on the left and the three time series on the right. Figs. ozsin and
    lobolusdecaras are projections of this curve.
    """
    t, theta, omega, alpha = (np.asarray(a, float) for a in (t, theta, omega, alpha))
    good = _finite(t, theta, omega, alpha)
    fig = new_figure(10.0, 4.6)
    gs = fig.add_gridspec(3, 2, width_ratios=(1.1, 1.4))
    ax3 = fig.add_subplot(gs[:, 0], projection="3d")
    s = _thin(int(good.sum()), 5000)
    sc = ax3.scatter(theta[good][s], omega[good][s], alpha[good][s], c=t[good][s], cmap="viridis", s=1.0,
                     depthshade=False)
    ax3.set_xlabel(L_THETA, fontsize=8)
    ax3.set_ylabel(L_OMEGA, fontsize=8)
    ax3.set_zlabel(L_ALPHA, fontsize=8)
    ax3.tick_params(labelsize=7)
    ax3.set_box_aspect(None, zoom=0.82)  # leave room for the axis labels inside the panel
    cb = fig.colorbar(sc, ax=ax3, shrink=0.5, pad=0.02, location="bottom", aspect=30)
    cb.set_label(L_T, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    for row, (values, label) in enumerate(((theta, L_THETA), (omega, L_OMEGA), (alpha, L_ALPHA))):
        ax = tidy(fig.add_subplot(gs[row, 1]))
        ax.plot(t, values, color=DATA_COLOR, linewidth=0.5)
        ax.set_ylabel(label)
        if row < 2:
            ax.tick_params(labelbottom=False)
    ax.set_xlabel(L_T)
    return fig


def ozsin_figure(theta_ext: np.ndarray, alpha_ext: np.ndarray, omega0: float, *,
                 omega0_err: float | None = None, omega0_raw: float | None = None) -> Figure:
    """Paper's Fig. ozsin: alpha at the turning points against theta_ext, with -Omega0^2 sin(theta_ext).

    Parameters
    ----------
    theta_ext : ndarray
        Angle at the turning points (omega = 0) [rad].
    alpha_ext : ndarray
        Angular acceleration there [rad/s^2].
    omega0 : float
        Model-free natural angular frequency (smoothing bias corrected if known) [rad/s].
    omega0_err : float, optional
        Its standard error [rad/s].
    omega0_raw : float, optional
        The direct fit through these points, drawn dashed when it differs [rad/s]; the
        residual panel is relative to it (else to ``omega0``).
    """
    theta_ext = np.asarray(theta_ext, float)
    alpha_ext = np.asarray(alpha_ext, float)
    fig = new_figure(7.0, 4.4)
    gs = fig.add_gridspec(2, 1, height_ratios=(3, 1))
    ax = tidy(fig.add_subplot(gs[0]))
    ax.plot(theta_ext, alpha_ext, "o", color=DATA_COLOR, markersize=3, label="turning points (data)")
    span = np.nanmax(np.abs(theta_ext)) if theta_ext.size else np.pi
    grid = np.linspace(-1.05 * span, 1.05 * span, 400)
    err = f" ± {omega0_err:.4f}" if omega0_err is not None else ""
    ax.plot(grid, -omega0 ** 2 * np.sin(grid), color=model_color("classic"), linewidth=1.2,
            label=rf"$-\Omega_0^2\sin\theta_\mathrm{{ext}}$, $\Omega_0$ = {omega0:.4f}{err} rad/s")
    ref = omega0
    if omega0_raw is not None and abs(omega0_raw - omega0) > 1e-9:
        ref = omega0_raw
        ax.plot(grid, -omega0_raw ** 2 * np.sin(grid), "--", color=model_color("power-law"), linewidth=1.0,
                label=rf"direct fit to these points, $\Omega_0$ = {omega0_raw:.4f} rad/s")
    ax.set_ylabel(r"$\alpha(\omega=0)$ [rad/s$^2$]")
    ax.tick_params(labelbottom=False)
    ax.legend(loc="upper right", fontsize=8)
    axr = tidy(fig.add_subplot(gs[1], sharex=ax))
    axr.plot(theta_ext, alpha_ext + ref ** 2 * np.sin(theta_ext), "o", color=DATA_COLOR, markersize=2.5)
    axr.axhline(0, color=model_color("power-law" if ref != omega0 else "classic"), linewidth=0.8)
    axr.set_xlabel(r"$\theta_\mathrm{ext}$ [rad]")
    axr.set_ylabel("residual\n[rad/s$^2$]")
    return fig


def delta_alpha_figure(t: np.ndarray, omega: np.ndarray, delta_alpha: np.ndarray) -> Figure:
    """Paper's Fig. lobolusdecaras: Delta alpha against omega for the whole run, coloured by time.

    The odd quadrants (Delta alpha * omega > 0: negative damping, eq. negativedampingdefinition)
    are shaded; the fraction of samples that fall in them is given in the legend.
    """
    t, omega, delta_alpha = (np.asarray(a, float) for a in (t, omega, delta_alpha))
    good = _finite(t, omega, delta_alpha)
    fig = new_figure(8.0, 4.8)
    ax = tidy(fig.add_subplot(), grid=False)
    s = _thin(int(good.sum()), 12000)
    sc = ax.scatter(omega[good][s], delta_alpha[good][s], c=t[good][s], cmap="viridis", s=1.5, linewidths=0,
                    zorder=2)
    neg = negative_damping_fraction(negative_damping_flags(omega, delta_alpha), good)
    ax.set_xlabel(L_OMEGA)
    ax.set_ylabel(L_DALPHA)
    ax.margins(0.04)
    _shade_negative_damping(ax)
    ax.fill_between([], [], color=NEGATIVE_FILL,
                    label=f"negative damping (Δα·ω > 0): {100 * neg:.1f} % of samples")
    ax.legend(loc="upper right", fontsize=8)
    cb = fig.colorbar(sc, ax=ax, pad=0.01)
    cb.set_label(L_T, fontsize=9)
    return fig


def hysteresis_figure(omega: np.ndarray, delta_alpha: np.ndarray, models: Mapping[str, tuple[np.ndarray, np.ndarray]],
                      *, power_law: tuple[np.ndarray, np.ndarray] | None = None,
                      seconds: float | None = None) -> Figure:
    """Paper's Fig. dissipativehysteresis: Delta alpha(omega) of the data and of each fitted model.

    Parameters
    ----------
    omega, delta_alpha : ndarray
        Data [rad/s], [rad/s^2] (already cut to the time window shown).
    models : mapping
        Model name -> (omega_model, delta_alpha_model) over the same window.
    power_law : (ndarray, ndarray), optional
        The classic model's dissipation with C_a = 0 as a curve (omega, a_diss).
    seconds : float, optional
        Length of the window shown [s], for the title.

    Two insets zoom on low speeds on both sides of omega = 0, where the odd (shaded) quadrants
    show negative damping.
    """
    omega = np.asarray(omega, float)
    delta_alpha = np.asarray(delta_alpha, float)
    good = _finite(omega, delta_alpha)
    fig = new_figure(10.0, 5.6)
    ax = tidy(fig.add_subplot(), grid=False)
    ax.plot(omega[good], delta_alpha[good], ".", color=DATA_COLOR, markersize=1.6, label="data", zorder=2)
    curves = []
    for i, (name, (om, da)) in enumerate(models.items()):
        (line,) = ax.plot(om, da, color=model_color(name, i), linewidth=1.1, label=f"{name} model", zorder=3)
        curves.append((om, da, line))
    if power_law is not None:
        (line,) = ax.plot(power_law[0], power_law[1], "--", color=model_color("power-law"), linewidth=1.1,
                          label=r"power-law (classic, $C_a=0$)", zorder=3)
        curves.append((power_law[0], power_law[1], line))
    ax.set_xlabel(L_OMEGA)
    ax.set_ylabel(r"$a_\mathrm{diss}+a_\mathrm{iner}=\Delta\alpha$ [rad/s$^2$]")
    ax.margins(0.03)
    _shade_negative_damping(ax)
    if seconds is not None:
        ax.set_title(f"first {seconds:g} s of the run")
    ax.legend(loc="upper center", fontsize=8, ncol=3, markerscale=5)
    wmax = float(np.nanmax(np.abs(omega[good]))) if good.any() else 1.0
    for side, loc in ((+1, [0.70, 0.58, 0.28, 0.36]), (-1, [0.02, 0.04, 0.28, 0.36])):
        _low_speed_inset(ax, loc, side, 0.12 * wmax, omega[good], delta_alpha[good], curves)
    return fig


def _low_speed_inset(ax: Axes, loc: list[float], side: int, width: float, omega: np.ndarray,
                     delta_alpha: np.ndarray, curves: list) -> None:
    """An inset of the (omega, Delta alpha) plot for 0 < side*omega < width."""
    inset = ax.inset_axes(loc)
    sel = (side * omega > 0) & (side * omega < width)
    inset.plot(omega[sel], delta_alpha[sel], ".", color=DATA_COLOR, markersize=1.5)
    for om, da, line in curves:
        om = np.asarray(om, float)
        da = np.asarray(da, float)
        m = (side * om > 0) & (side * om < width)
        inset.plot(om, np.where(m, da, np.nan), color=line.get_color(), linestyle=line.get_linestyle(),
                   linewidth=1.0)
    inset.set_xlim(*sorted((0.0, side * width)))
    if sel.any():
        lo, hi = np.percentile(delta_alpha[sel], [1, 99])
        pad = 0.15 * (hi - lo) + 1e-9
        inset.set_ylim(min(lo - pad, -pad), max(hi + pad, pad))
    tidy(inset, grid=False)
    inset.tick_params(labelsize=6)
    inset.set_facecolor("white")
    _shade_negative_damping(inset)
    inset.text(0.5, 0.97, "low speed, ω " + ("> 0" if side > 0 else "< 0"), transform=inset.transAxes,
               ha="center", va="top", fontsize=7, bbox={"facecolor": "white", "edgecolor": "none", "pad": 1})


def theta_fit_figure(t: np.ndarray, theta: np.ndarray, models: Mapping[str, np.ndarray],
                     residuals: Mapping[str, np.ndarray], *, title: str = "",
                     window: tuple[float, float] | None = None) -> Figure:
    """Paper's Figs. spuriousosc, superfit, S2, S3: theta(t) data and model(s) with residuals.

    Parameters
    ----------
    t, theta : ndarray
        Data time [s] and angle [rad] (already cut to the window shown).
    models : mapping
        Model name -> model angle [rad] at ``t``.
    residuals : mapping
        Model name -> ``theta - theta_model`` [rad] at ``t``.
    title : str
        Axes title.
    window : (float, float), optional
        The fitted time window [s]; times outside it are shaded grey.
    """
    t = np.asarray(t, float)
    fig = new_figure(10.0, 5.0)
    gs = fig.add_gridspec(2, 1, height_ratios=(2.2, 1))
    ax = tidy(fig.add_subplot(gs[0]))
    ax.plot(t, theta, ".", color=DATA_COLOR, markersize=1.5, label="data")
    for i, (name, th) in enumerate(models.items()):
        ax.plot(t, th, color=model_color(name, i), linewidth=0.9, label=f"{name} model")
    ax.set_ylabel(L_THETA)
    ax.tick_params(labelbottom=False)
    ax.legend(loc="upper right", fontsize=8, markerscale=5)
    if title:
        ax.set_title(title)
    axr = tidy(fig.add_subplot(gs[1], sharex=ax))
    for i, (name, r) in enumerate(residuals.items()):
        r = np.asarray(r, float)
        rms = float(np.sqrt(np.nanmean(r ** 2))) if np.isfinite(r).any() else float("nan")
        axr.plot(t, r, color=model_color(name, i), linewidth=0.6, label=f"{name}: RMS {1e3 * rms:.2f} mrad")
    axr.axhline(0, color="0.4", linewidth=0.6)
    axr.set_xlabel(L_T)
    axr.set_ylabel(r"$\theta-\theta_\mathrm{model}$ [rad]")
    if t.size:
        ax.set_xlim(t.min(), t.max())
        if window is not None:
            spans = [(lo, hi) for lo, hi in ((t.min(), window[0]), (window[1], t.max())) if hi > lo]
            for a in (ax, axr):
                for i, (lo, hi) in enumerate(spans):
                    a.axvspan(lo, hi, color="0.85", zorder=0, linewidth=0,
                              label="not fitted" if a is axr and i == 0 else None)
    axr.legend(loc="upper right", fontsize=8)
    return fig


def amplitudes_figure(t: np.ndarray, a_theta: np.ndarray, a_omega: np.ndarray, phase_speed: np.ndarray, *,
                      model: tuple[str, np.ndarray, np.ndarray, np.ndarray] | None = None) -> Figure:
    """Paper's Fig. schluck: A_theta = sin(theta/2), A_omega = omega/(2 Omega0) and the phase speed Phi.

    Parameters
    ----------
    t, a_theta, a_omega, phase_speed : ndarray
        Data time [s], amplitudes [1] and phase speed [rad/s] (eqs. amplitudes, phasespeed).
    model : (name, t, A_theta, A_omega), optional
        The same amplitudes computed from a fitted model's curves.
    """
    t = np.asarray(t, float)
    fig = new_figure(10.0, 5.2)
    gs = fig.add_gridspec(2, 1, height_ratios=(1.4, 1))
    ax = tidy(fig.add_subplot(gs[0]))
    ax.plot(t, a_theta, color="#c0392b", linewidth=0.6, label=r"$\mathcal{A}_\theta=\sin(\theta/2)$ data")
    ax.plot(t, a_omega, color="#2471a3", linewidth=0.6, label=r"$\mathcal{A}_\omega=\omega/(2\Omega_0)$ data")
    if model is not None:
        name, tm, at, aw = model
        ax.plot(tm, at, "--", color="#641e16", linewidth=0.7, label=rf"$\mathcal{{A}}_\theta$ {name} model")
        ax.plot(tm, aw, "--", color="#154360", linewidth=0.7, label=rf"$\mathcal{{A}}_\omega$ {name} model")
    ax.set_ylabel("amplitude [1]")
    ax.tick_params(labelbottom=False)
    ax.set_ylim(-1.08, 1.5)  # |A| <= 1: the headroom keeps the legend off the curves
    ax.legend(loc="upper center", fontsize=8, ncol=4 if model is not None else 2)
    axp = tidy(fig.add_subplot(gs[1], sharex=ax))
    axp.plot(t, phase_speed, color=DATA_COLOR, linewidth=0.5, label=r"$\Phi=d\phi/dt$ data")
    finite = np.asarray(phase_speed, float)
    finite = finite[np.isfinite(finite)]
    if finite.size:
        lo, hi = np.percentile(finite, [0.5, 99.5])
        pad = 0.1 * (hi - lo) + 1e-9
        axp.set_ylim(lo - pad, hi + pad)
    axp.set_xlabel(L_T)
    axp.set_ylabel(r"$\Phi$ [rad/s]")
    axp.legend(loc="upper right", fontsize=8)
    if t.size:
        ax.set_xlim(t.min(), t.max())
    return fig


def nyquist_figure(t: np.ndarray, a_theta: np.ndarray, a_omega: np.ndarray, omega0: float, *,
                   model: tuple[str, np.ndarray, np.ndarray, np.ndarray] | None = None) -> Figure:
    """Paper's Fig. nyquist: (A_omega, A_theta) against time in natural periods t Omega0 / (2 pi).

    Two 3-D views, the (A_omega, A_theta) plane seen from above, and the normalised mechanical
    energy A^2 = A_theta^2 + A_omega^2 (eq. amplitudesobservable), on a log scale when it spans a decade.

    Parameters
    ----------
    t, a_theta, a_omega : ndarray
        Data time [s] and amplitudes [1].
    omega0 : float
        Natural angular frequency that scales time [rad/s].
    model : (name, t, A_theta, A_omega), optional
        A fitted model's amplitudes, drawn as a line.
    """
    t, a_theta, a_omega = (np.asarray(a, float) for a in (t, a_theta, a_omega))
    good = _finite(t, a_theta, a_omega)
    tt, at, aw = t[good], a_theta[good], a_omega[good]
    cycles = tt * omega0 / (2 * np.pi)
    s = _thin(tt.size, 4000)
    fig = new_figure(10.0, 8.0)
    mcol = model_color(model[0]) if model is not None else None
    for k, (elev, azim) in enumerate(((22, -60), (12, -135))):
        ax = fig.add_subplot(2, 2, k + 1, projection="3d")
        ax.scatter(aw[s], at[s], cycles[s], s=0.6, color="0.6", depthshade=False, label="data")
        if model is not None:
            name, tm, mt, mw = model
            ax.plot(mw, mt, np.asarray(tm, float) * omega0 / (2 * np.pi), color=mcol, linewidth=0.6,
                    label=f"{name} model")
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel(r"$\mathcal{A}_\omega$ [1]", fontsize=8)
        ax.set_ylabel(r"$\mathcal{A}_\theta$ [1]", fontsize=8)
        ax.set_zlabel(r"$t\Omega_0/2\pi$ [periods]", fontsize=8)
        ax.tick_params(labelsize=7)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(4))
        if k == 0:
            ax.legend(loc="upper left", fontsize=7, markerscale=6)
    ax = tidy(fig.add_subplot(2, 2, 3))
    ax.scatter(aw[s], at[s], c=cycles[s], cmap="viridis", s=1.0, linewidths=0)
    if model is not None:
        ax.plot(model[3], model[2], color=mcol, linewidth=0.4, alpha=0.8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(r"$\mathcal{A}_\omega=\omega/(2\Omega_0)$ [1]")
    ax.set_ylabel(r"$\mathcal{A}_\theta=\sin(\theta/2)$ [1]")
    ax.set_title("seen from above (colour: time)")
    ax = tidy(fig.add_subplot(2, 2, 4))
    energy = at ** 2 + aw ** 2
    ax.plot(cycles, energy, ".", color=DATA_COLOR, markersize=1.0, label="data")
    if model is not None:
        name, tm, mt, mw = model
        ax.plot(np.asarray(tm, float) * omega0 / (2 * np.pi), np.asarray(mt) ** 2 + np.asarray(mw) ** 2,
                color=mcol, linewidth=0.8, label=f"{name} model")
    positive = energy[energy > 0]
    if positive.size and positive.max() > 10 * positive.min():  # log scale only when it decays by decades
        ax.set_yscale("log")
    ax.set_xlabel(r"$t\Omega_0/2\pi$ [natural periods]")
    ax.set_ylabel(r"$\mathcal{A}^2=\mathcal{A}_\theta^2+\mathcal{A}_\omega^2$ [1]")
    ax.set_title("normalised mechanical energy")
    ax.legend(loc="upper right", fontsize=8, markerscale=5)
    return fig


def joint_runs_figure(runs: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]], *, model: str,
                      ncols: int = 2) -> Figure:
    """A joint fit run by run: each run's theta(t) with the jointly fitted model, and its residual.

    Parameters
    ----------
    runs : mapping
        Run id -> (t [s], theta [rad], theta_model [rad]), the model simulated from the run's own
        fitted initial state with the values it takes at the joint optimum (fit_runs.parquet).
    model : str
        The model's name (colour, legend).
    ncols : int
        Runs per row.
    """
    names = list(runs)
    ncols = max(1, min(ncols, len(names)))
    nrows = max(1, -(-len(names) // ncols))
    fig = new_figure(10.0, 3.0 * nrows)
    outer = fig.add_gridspec(nrows, ncols)
    color = model_color(model)
    for k, name in enumerate(names):
        t, theta, theta_model = (np.asarray(a, float) for a in runs[name])
        inner = outer[k // ncols, k % ncols].subgridspec(2, 1, height_ratios=(2.0, 1.0), hspace=0.05)
        ax = tidy(fig.add_subplot(inner[0]))
        ax.plot(t, theta, ".", color=DATA_COLOR, markersize=1.0, label="data")
        ax.plot(t, theta_model, color=color, linewidth=0.8, label=f"{model}, joint fit")
        r = theta - theta_model
        rms = float(np.sqrt(np.nanmean(r ** 2))) if np.isfinite(r).any() else float("nan")
        ax.set_title(f"{name}: residual RMS {1e3 * rms:.2f} mrad")
        ax.tick_params(labelbottom=False)
        ax.set_ylabel(L_THETA)
        if k == 0:
            ax.legend(loc="upper right", fontsize=7, markerscale=5)
        axr = tidy(fig.add_subplot(inner[1], sharex=ax))
        axr.plot(t, r, color=color, linewidth=0.5)
        axr.axhline(0, color="0.4", linewidth=0.6)
        axr.set_ylabel(r"$\theta-\theta_\mathrm{model}$", fontsize=8)
        axr.set_xlabel(L_T)
        if t.size:
            ax.set_xlim(t.min(), t.max())
    return fig
