"""The solver kernels: plain arrays and scalars in, preallocated arrays out.

Three kernels, each a pure-Python function (``*_py``) that numba compiles unchanged on first
use (``*_nb``, :mod:`.jit`); nothing is compiled or even imported from numba at import time.
All read the packed coefficient vector of :mod:`pendtrack.models.terms`, so one kernel serves
every composition of terms.

* :func:`~.rk4.rk_kernel_py` (:mod:`.rk4`) -- classical RK4 with sub-steps and sgn(omega)
  events, for the models without memory;
* :func:`~.rk4_sensitivity.rk_sens_kernel_py` (:mod:`.rk4_sensitivity`) -- the same with the
  forward sensitivities, its partials folded from the terms' declared ``dfn``;
* :func:`~.predictor_corrector.pc_kernel_py` (:mod:`.predictor_corrector`) -- the paper's
  predictor-corrector with the Grunwald-Letnikov memory.

Under them: :mod:`.folds` (the per-step functions folded from the term declarations, shared
with the vectorised right-hand side), :mod:`.rotation` (sin/cos carried by rotations), and
:mod:`.jit` (compilation, and the cache key that holds every kernel file's and declaration's
source: :func:`~.jit.declarations_stamp`).
"""

from __future__ import annotations

from pendtrack.models.kernels.folds import accel_free, accel_smooth, direction, friction_pair
from pendtrack.models.kernels.jit import (
    compile_kernels, declarations_stamp, pc_kernel_nb, rk_kernel_nb, rk_sens_kernel_nb,
)
from pendtrack.models.kernels.predictor_corrector import pc_kernel_py
from pendtrack.models.kernels.rk4 import rk_kernel_py
from pendtrack.models.kernels.rk4_sensitivity import rk_sens_kernel_py

__all__ = [
    "accel_free", "accel_smooth", "compile_kernels", "declarations_stamp", "direction", "friction_pair",
    "pc_kernel_nb", "pc_kernel_py", "rk_kernel_nb", "rk_kernel_py", "rk_sens_kernel_nb", "rk_sens_kernel_py",
]
