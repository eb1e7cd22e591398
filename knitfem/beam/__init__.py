"""Geometrically exact (Simo–Reissner) rods assembled with scikit-fem."""
from .model import BeamModel, BeamState
from .rod import Rod
from .section import Section

__all__ = ["BeamModel", "BeamState", "Rod", "Section"]
