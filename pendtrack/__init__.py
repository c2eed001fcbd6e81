"""pendtrack: from a fisheye video of a physical pendulum to fitted physical models.

``import pendtrack as pt`` gives the pipeline the CLI runs (:mod:`pendtrack.api`): ``pt.track``,
``pt.angle``, ``pt.kinematics``, ``pt.read_record``, ``pt.fit``, ``pt.discover``, ``pt.simulate``,
``pt.render``, ``pt.load``. Importing the package does no work: no numba compilation, no file
access, and none of numpy, pandas, OpenCV or numba is imported until one of those names is used
(PEP 562 module ``__getattr__``).
"""

import sys
import types
from typing import Any

from pendtrack.version import __version__

#: the library door's names, imported from pendtrack.api on first use
DOOR = ("track", "angle", "kinematics", "read_record", "fit", "discover", "simulate", "render", "load",
        "FitSet", "ModelFit", "Discovery", "Run")

__all__ = ["__version__", *DOOR]


def __getattr__(name: str) -> Any:
    if name in DOOR:
        from pendtrack import api

        return getattr(api, name)
    raise AttributeError(f"module 'pendtrack' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)


#: door functions named as core subpackages: ``pt.track`` is the function, ``pendtrack.track.tracker`` the module
SHADOWED = frozenset({"track", "kinematics", "render"})


class _Package(types.ModuleType):
    """The package's module type: ``pt.track``, ``pt.kinematics``, ``pt.render`` are the door's functions.

    Importing ``pendtrack.track`` binds that subpackage as the attribute ``track``, which a module
    ``__getattr__`` never overrides. Here those three names always give the door's functions; the
    subpackages stay in ``sys.modules`` (``from pendtrack.track import tracker`` is unchanged; an
    ``import pendtrack.track.tracker as tracker`` would find the function and fail).
    """

    def __getattribute__(self, name: str) -> Any:
        if name in SHADOWED:
            return __getattr__(name)
        return super().__getattribute__(name)


sys.modules[__name__].__class__ = _Package
