"""Curves only: planar elastica guesses, the Ω loop, fabric tiling (no mechanics)."""
from .elastica import planar_elastica

__all__ = ["planar_elastica"]
