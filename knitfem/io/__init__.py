"""Output formats shared by the beam and B-spline models (meshio .vtu, .pvd series)."""
from .vtk import beam_mesh, curve_mesh, write_beam_state, write_mesh, write_series

__all__ = ["beam_mesh", "curve_mesh", "write_beam_state", "write_mesh", "write_series"]
