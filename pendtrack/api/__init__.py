"""The library door: the pipeline the CLI runs, called from Python (``import pendtrack as pt``).

Each function takes and returns in-memory objects -- DataFrames carrying their provenance in
``.attrs["provenance"]``, and result objects that show themselves in a notebook (``_repr_html_``)
and draw the report's figures (``.plot()``) -- and runs the very stage the CLI runs, with the
CLI's option names and defaults (:mod:`pendtrack.api.options`), so a fit here equals
``fit_<model>.json`` of ``pendtrack fit`` on the same input to the last digit. A user error raises
the CLI's one-line :class:`pendtrack.errors.PendtrackError`.

The stages write files; here they write into a scratch folder that is removed afterwards, or into
``out=`` (the CLI's ``--out``), which then holds exactly what the CLI writes and :func:`load` reads.
"""

from pendtrack.api.findings import Discovery, discover
from pendtrack.api.fits import FitSet, ModelFit, fit
from pendtrack.api.folders import Run, load
from pendtrack.api.records import angle, kinematics, read_record, render, simulate, track


__all__ = ["Discovery", "FitSet", "ModelFit", "Run", "angle", "discover", "fit", "kinematics", "load",
           "read_record", "render", "simulate", "track"]
