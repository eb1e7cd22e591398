"""knitfem: how knitted fabrics curl, from one yarn loop to a swatch.

The public API of the beam core::

    from knitfem import BeamModel, Rod, Section
"""
from .numba_cache import configure as _configure_numba_cache

_configure_numba_cache()          # before any kernel is defined (see knitfem.numba_cache)

from .beam import BeamModel, BeamState, Rod, Section  # noqa: E402
from .solve import NewtonError, SteppingError  # noqa: E402

__version__ = "0.1.0"
__all__ = ["BeamModel", "BeamState", "Rod", "Section", "NewtonError", "SteppingError"]
