"""MATLAB data files (``.mat``, versions 4 to 7), read as the text table they hold.

A rig logged from MATLAB or Simulink is often saved with ``save('run.mat', 'data')``: one numeric matrix, a
sample per row (``data(:, 1)`` the time, ``data(:, 2)`` the angle), or one vector per quantity (``t``,
``theta``). :func:`matlab_lines` reads the file with :func:`scipy.io.loadmat` and writes what it holds as the
lines of a comma-separated table, each value with every digit of its double (``repr``), so that
:func:`pendtrack.tables.text.read_text` reads it as it reads any table: a matrix has no header (``--columns``
says what its columns are, and a unit they cannot be in is refused as in a text file); equal-length vectors get
their variable names as the header. A matrix stored with a sample per column (2 rows of 844) is read along its
longer side. MATLAB 7.3 files are HDF5, which scipy does not read: an error says how to save the file instead.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pendtrack.errors import ConfigError

MATLAB_SUFFIXES = frozenset({".mat"})
HDF5_MARK = b"MATLAB 7.3 MAT-file"  # the text header of a version 7.3 file (an HDF5 file behind a MATLAB header)
SAVE_ADVICE = "save it with save(FILE, VARIABLES, '-v7') or export a CSV"


def _numeric(value: object) -> np.ndarray | None:
    """``value`` as a real float array if it is a numeric MATLAB array (no struct, cell, text or complex)."""
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf" or value.size < 2:
        return None
    return np.asarray(value, dtype=float)


def _describe(name: str, value: object) -> str:
    if isinstance(value, np.ndarray):
        kind = {"O": "a cell array", "V": "a struct", "U": "text", "S": "text", "c": "complex numbers"}.get(
            value.dtype.kind, "numbers")
        return f"{name} ({'x'.join(str(s) for s in value.shape)} {kind})"
    return f"{name} ({type(value).__name__})"


def matlab_lines(path: Path) -> list[tuple[int, str]]:
    """The samples of a MATLAB ``.mat`` file as numbered lines of a comma-separated table.

    Parameters
    ----------
    path : Path
        A ``.mat`` file of version 4, 5 or 7.

    Returns
    -------
    list of (int, str)
        For one matrix: ``(k + 1, row k)``, a sample per row, no header. For equal-length vectors:
        ``(1, "name1,name2,...")``, then ``(k + 2, row k)``.

    Raises
    ------
    ConfigError
        A version 7.3 (HDF5) file, a file scipy cannot read, or one that holds no matrix of samples (structs,
        Simulink objects, vectors of different lengths), naming what it holds.
    """
    with open(path, "rb") as fh:
        head = fh.read(128)
    if HDF5_MARK in head:
        raise ConfigError(f"a MATLAB 7.3 file (HDF5), which pendtrack does not read: {SAVE_ADVICE}")
    from scipy.io import loadmat  # scipy.io pulls in more than the table reader needs elsewhere

    try:
        variables = {k: v for k, v in loadmat(path, squeeze_me=False).items() if not k.startswith("__")}
    except Exception as exc:  # noqa: BLE001 - scipy raises many kinds for a file it cannot parse
        raise ConfigError(f"not a MATLAB data file scipy can read ({type(exc).__name__}: {exc})") from None
    arrays = {k: a for k, a in ((k, _numeric(v)) for k, v in variables.items()) if a is not None}
    matrices = {k: a for k, a in arrays.items() if a.ndim == 2 and min(a.shape) > 1}
    vectors = {k: a.ravel() for k, a in arrays.items() if a.ndim <= 2 and min(a.shape, default=0) == 1}
    held = ", ".join(_describe(k, v) for k, v in variables.items()) or "no variables"
    if len(matrices) == 1 and not vectors:
        (matrix,) = matrices.values()
        rows = matrix if matrix.shape[0] >= matrix.shape[1] else matrix.T
        return [(k + 1, ",".join(repr(float(v)) for v in row)) for k, row in enumerate(rows)]
    lengths = {a.size for a in vectors.values()}
    if not matrices and len(lengths) == 1 and (len(vectors) > 1 or len(variables) == 1):
        names, columns = list(vectors), np.column_stack(list(vectors.values()))
        return [(1, ",".join(names))] + [(k + 2, ",".join(repr(float(v)) for v in row))
                                         for k, row in enumerate(columns)]
    raise ConfigError(f"holds {held}: pendtrack reads one numeric matrix (a sample per row) or vectors of one "
                      "length (t, theta, ...) from a MATLAB file; save those alone, or export a CSV")
