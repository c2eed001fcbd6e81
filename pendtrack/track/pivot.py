"""The pivot of a measured x, y path (a table of positions without ``--pivot``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pendtrack.errors import ArtifactError
from pendtrack.track.circle import fit_circle

MIN_ARC_RAD = 0.1  # a path spanning less arc (~6 deg) does not locate its pivot: --pivot is needed


def fitted_pivot(x: np.ndarray, y: np.ndarray) -> tuple[tuple[float, float], dict[str, Any]]:
    """The pivot of an x, y path: the centre of a robust circle fit (:func:`pendtrack.track.circle.fit_circle`).

    Parameters
    ----------
    x, y : ndarray
        Positions (any length unit).

    Returns
    -------
    (px, py), facts
        The centre, and ``radius``, ``rms`` (radial residual) and ``arc_deg`` for the provenance.

    Raises
    ------
    ArtifactError
        The path covers too little arc (below :data:`MIN_ARC_RAD`) to locate the centre.
    """
    scale = float(np.hypot(np.ptp(x), np.ptp(y))) if x.size else 0.0
    fit = fit_circle(x, y, f_scale=max(0.01 * scale, 1e-12)) if x.size >= 3 and scale > 0 else None
    if fit is None or fit.arc_span < MIN_ARC_RAD:
        span = 0.0 if fit is None else math.degrees(fit.arc_span)
        raise ArtifactError(f"the x, y path spans {span:.2g} deg of arc, too little to fit its pivot: "
                            "give --pivot X Y")
    return (fit.xc, fit.yc), {"radius": fit.radius, "rms": fit.rms, "arc_deg": math.degrees(fit.arc_span)}
