"""Compiling the kernels with numba, and the key of numba's on-disk cache.

Every kernel is a pure-Python function (``*_py``) that numba compiles unchanged on first use
(:func:`rk_kernel_nb`, :func:`pc_kernel_nb`, :func:`rk_sens_kernel_nb`, ``@njit(cache=True)``);
nothing is compiled or even imported from numba at import time. numba keys its cache on the
file of the compiled function only -- this one: the kernels are compiled behind a closure
(:func:`_stamped`) holding :func:`declarations_stamp`, the hash of every other source file the
kernels compile (the term declarations and every module of this package), so a changed term
or kernel recompiles them instead of loading a stale one.

Compilation (:func:`_compile`, ~8 s of CPU): ``error_model="numpy"`` and ``fastmath`` limited to
``contract``/``arcp`` (fused multiply-add, reciprocal division) for the kernels, full
``fastmath`` only for the GL dot product (vectorised reduction). The numba kernels
therefore agree with their Python twins to rounding (~1e-13 rad over 600 steps), not
bit for bit.
"""

from __future__ import annotations

import numpy as np

from pendtrack.models import terms as T
from pendtrack.models.declare import Term
from pendtrack.models.gl import gl_weights
from pendtrack.models.kernels.folds import (
    _FOLDED, _GRAD_FOLDED, _SCATTER_FOLDED, _friction_seed, accel_free, accel_smooth, accel_terms, direction,
    forcing_at, friction_mean, friction_pair, grad_friction, grad_smooth, unpack,
)
from pendtrack.models.kernels.predictor_corrector import (
    binomial_series, gl_dot, memory_fn, memory_pair, memory_pair_next, pc_kernel_py, series_ratio_pow,
)
from pendtrack.models.kernels.rk4 import (
    locate_stop, restart_at_stop, rk4_stage, rk4_step, rk_kernel_py, sample_alpha, start_outputs,
)
from pendtrack.models.kernels.rk4_sensitivity import accel_grad, rk4_length_derivative, rk4_sens_step, rk_sens_kernel_py
from pendtrack.models.kernels.rotation import sin_cos_after, sin_cos_at
from pendtrack.models.terms import K_HAS_MEMORY, empty_coeffs

#: The modules whose functions the kernels compile (their source enters :func:`declarations_stamp`).
KERNEL_MODULES = (
    "pendtrack.models.kernels.folds", "pendtrack.models.kernels.rotation", "pendtrack.models.kernels.rk4",
    "pendtrack.models.kernels.rk4_sensitivity", "pendtrack.models.kernels.predictor_corrector",
)

_NB: dict[str, object] = {}


def declarations_stamp() -> str:
    """sha256 of the source of every module whose code the kernels compile besides this one.

    numba's cache is keyed on the compiled function's own file only (this one): a changed or
    added term in :mod:`pendtrack.models.terms`, or a changed kernel in a sibling module, would
    otherwise load a stale kernel. The stamp enters the cache key through :func:`_stamped`.
    """
    import hashlib
    import sys
    from pathlib import Path

    modules = {T.__name__, Term.__module__, gl_weights.__module__, *KERNEL_MODULES}
    modules.update(t.fn.__module__ for t in (T.BASE, *T.TERMS.values()) if t.fn is not None)
    digest = hashlib.sha256()
    for name in sorted(modules):
        digest.update(name.encode())
        digest.update(Path(sys.modules[name].__file__).read_bytes())
    return digest.hexdigest()


def _stamped(kernel, stamp):  # noqa: ANN001, ANN202
    """``kernel`` behind a closure whose cells (``kernel``, ``stamp``) numba hashes into its cache key."""
    def run(coeffs, n_steps, h, t_start, theta0, omega0, option, forcing,
            out_theta, out_omega, out_alpha):  # noqa: ANN001, ANN202
        if stamp:  # always true: the reference puts the stamp into the closure
            kernel(coeffs, n_steps, h, t_start, theta0, omega0, option, forcing, out_theta, out_omega, out_alpha)
    return run


def _stamped_sens(kernel, stamp):  # noqa: ANN001, ANN202
    """:func:`_stamped` for the sensitivity kernel's signature."""
    def run(coeffs, slot_index, dcoeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
            dtheta0, domega0, out_theta, out_omega, out_alpha, out_dtheta, out_domega):  # noqa: ANN001, ANN202
        if stamp:  # always true: the reference puts the stamp into the closure
            kernel(coeffs, slot_index, dcoeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
                   dtheta0, domega0, out_theta, out_omega, out_alpha, out_dtheta, out_domega)
    return run


# error_model="numpy": no zero-division checks in the loops (packed models never divide by 0);
# fastmath contract/arcp only (fused multiply-add, division by reciprocal): the per-step
# dependency chain gets ~30 % shorter; no reassociation, no NaN/inf assumptions. The
# twins then differ by rounding only (measured <= 4e-13 rad over 600 steps; test 1e-12)
_OPTIONS = {"error_model": "numpy", "fastmath": {"contract", "arcp"}}


def _register() -> None:
    """Register the helpers with numba (once per process).

    The small per-step helpers -- the declared terms' formulas and their folds included --
    are inlined at numba-IR level (a call each would cost more than the arithmetic).
    """
    if "registered" in _NB:
        return
    from numba.extending import overload, register_jitable
    from numba.np.unsafe.ndarray import to_fixed_tuple

    n_coeffs = T.N_COEFFS

    @overload(unpack, inline="always")
    def _unpack(c):  # noqa: ANN001, ANN202
        return lambda c: to_fixed_tuple(c, n_coeffs)

    # the folds of the declared formulas: ordinary calls that LLVM inlines (numba's IR-level
    # inlining of the nested folds would cost minutes of compilation)
    formulas = tuple(t.fn for t in (T.BASE, *T.TERMS.values()) if t.fn is not None)
    derivatives = tuple(t.dfn for t in (T.BASE, *T.TERMS.values()) if t.dfn is not None)
    for fn in (*formulas, *_FOLDED, _friction_seed, *derivatives, *_GRAD_FOLDED, *_SCATTER_FOLDED):
        register_jitable(fn)
    for fn in (accel_smooth, friction_pair, friction_mean, accel_terms, accel_free, forcing_at, memory_fn,
               memory_pair, memory_pair_next, series_ratio_pow, sin_cos_after, sin_cos_at, grad_smooth, grad_friction,
               sample_alpha, restart_at_stop, rk4_stage, start_outputs):
        register_jitable(inline="always")(fn)
    for fn in (direction, rk4_step, locate_stop, rk4_length_derivative):  # larger: ordinary calls (inlining costs compile time)
        register_jitable(fn)
    # the sensitivity step and its partials pass arrays: inlined, so that no call passes (and
    # reference-counts) them per stage (3x faster, measured)
    register_jitable(inline="always")(accel_grad)
    register_jitable(inline="always")(rk4_sens_step)
    register_jitable(fastmath=True)(gl_dot)
    register_jitable(binomial_series)
    register_jitable(gl_weights)
    for kernel in (rk_kernel_py, pc_kernel_py, rk_sens_kernel_py):
        register_jitable(**_OPTIONS)(kernel)
    _NB["registered"] = True


def _compile() -> None:
    """Register the helpers with numba, build both kernels and compile them (or load the cache).

    numba's pedantic SSA check warns about inlined variables, which is harmless, so those
    warnings are silenced during this one compilation.
    """
    import warnings

    from numba import njit
    from numba.core.errors import NumbaIRAssumptionWarning

    _register()
    stamp = declarations_stamp()
    compiled = {}
    for name, kernel in (("rk", rk_kernel_py), ("pc", pc_kernel_py)):
        compiled[name] = njit(cache=True, **_OPTIONS)(_stamped(kernel, stamp))
    c = np.asarray(empty_coeffs())
    c[K_HAS_MEMORY] = 1.0
    out = np.zeros(3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
        for kern in compiled.values():
            kern(c, 1, 0.1, 0.0, 0.1, 0.0, 1, np.zeros(0), out, out, out)
    _NB.update(compiled)


def rk_sens_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`rk_sens_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "rk_sens" not in _NB:
        import warnings

        from numba import njit
        from numba.core.errors import NumbaIRAssumptionWarning

        _register()
        kern = njit(cache=True, **_OPTIONS)(_stamped_sens(rk_sens_kernel_py, declarations_stamp()))
        c = np.asarray(empty_coeffs())
        c[T.K_SIN] = 1.0
        out = np.zeros(3)
        d = np.zeros((3, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            kern(c, np.zeros(1, dtype=np.int64), np.zeros((1, 1)), 1, 0.1, 0.0, 0.1, 0.0, 1, np.zeros(0),
                 np.zeros(1), np.zeros(1), out, out, out, d, d)
        _NB["rk_sens"] = kern
    return _NB["rk_sens"]


def rk_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`rk_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "rk" not in _NB:
        _compile()
    return _NB["rk"]


def pc_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`pc_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "pc" not in _NB:
        _compile()
    return _NB["pc"]


def compile_kernels() -> None:
    """Compile every numba kernel now (or load it from numba's on-disk cache).

    ``make setup`` calls it, so a fresh clone's first run does not compile; results never depend
    on it (a fit counts its work, not its seconds), only the first run's wall time does.
    """
    rk_kernel_nb()
    pc_kernel_nb()
    rk_sens_kernel_nb()
