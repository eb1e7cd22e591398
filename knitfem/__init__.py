"""knitfem: how knitted fabrics curl, from one yarn loop to a swatch.

The public API of the beam core::

    from knitfem import BeamModel, Rod, Section
"""
from .beam import BeamModel, BeamState, Rod, Section
from .solve import NewtonError, SteppingError

__version__ = "0.1.0"
__all__ = ["BeamModel", "BeamState", "Rod", "Section", "NewtonError", "SteppingError"]
