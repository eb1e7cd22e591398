"""Output formats shared by the beam and B-spline models (meshio .vtu, .pvd series),
written atomically (:mod:`knitfem.io.atomic`); run folders with their manifest
(:mod:`knitfem.io.run`)."""
from .atomic import save_figure, write_csv, write_json, write_text
from .vtk import beam_mesh, curve_mesh, write_beam_state, write_mesh, write_series

__all__ = ["beam_mesh", "curve_mesh", "save_figure", "write_beam_state", "write_csv",
           "write_json", "write_mesh", "write_series", "write_text"]
