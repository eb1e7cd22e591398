"""Knit swatches (:class:`knitfem.geometry.swatch.Swatch`) as .vtu files and renders.

One ``line`` cell per yarn segment (meshio cannot write ``polyline``).  Point
data: ``tangent`` (unit), ``radius``, ``yarn`` and ``course`` (for colouring;
a point takes the course of the segment leaving it); cell data:
``yarn``, ``course`` (-1 / n_course on the bottom / top bind-off), ``wale``
(-1 on turn-arounds), ``bindoff`` and ``turn`` (0/1).
"""
from pathlib import Path

import numpy as np

from .vtk import curve_mesh, write_mesh


def swatch_mesh(swatch):
    """meshio.Mesh of every yarn centreline of ``swatch``."""
    yarns = swatch.yarns
    point_data = {"tangent": [y.tangents for y in yarns],
                  "radius": [np.full(len(y.points), swatch.radius) for y in yarns],
                  "yarn": [np.full(len(y.points), i, dtype=np.int32) for i, y in enumerate(yarns)],
                  "course": [np.append(y.course, y.course[-1]).astype(np.int32) for y in yarns]}
    cell_data = {"yarn": [np.full(len(y.points) - 1, i, dtype=np.int32)
                          for i, y in enumerate(yarns)],
                 "course": [y.course.astype(np.int32) for y in yarns],
                 "wale": [y.wale.astype(np.int32) for y in yarns],
                 "bindoff": [np.full(len(y.points) - 1, int(y.bindoff), dtype=np.int32)
                             for y in yarns],
                 "turn": [y.turn.astype(np.int32) for y in yarns]}
    return curve_mesh([y.points for y in yarns], point_data, cell_data)


def render_swatch(swatch, path, *, mesh=None, view=(0.15, -0.3, 1.0), window_size=None,
                  zoom=None):
    """Off-screen pyvista tubes of the yarn radius to ``path`` (.png), seen from
    the knit face (+z), coloured by course (the bind-off helices are courses
    -1 and n_course); the window follows the swatch's aspect.  Returns the path."""
    from ..viz.render import render_rods
    mesh = swatch_mesh(swatch) if mesh is None else mesh
    width, height = np.ptp(mesh.points[:, 0]), np.ptp(mesh.points[:, 1])
    if window_size is None:              # the longer side 800 px + margins
        scale = 800.0 / max(width, height)
        window_size = (int(max(500, width * scale + 120)), int(max(500, height * scale + 120)))
    if zoom is None:                     # the camera fits the bounding sphere: loose when tall
        zoom = 1.6 if max(width, height) > 2.0 * min(width, height) else 1.2
    return render_rods(path, mesh, swatch.radius, scalars="course", view=view,
                       camera_up=(0, 1, 0), window_size=window_size, zoom=zoom)


def write_swatch(swatch, out_dir, render=True, *, name=None, view=(0.15, -0.3, 1.0),
                 window_size=None):
    """Write ``<name>.vtu`` (default name ``knit_<nw>x<nc>``) and, with
    ``render``, ``<name>.png`` (:func:`render_swatch`).  Returns the paths."""
    out = Path(out_dir)
    name = name or f"knit_{swatch.n_wale}x{swatch.n_course}"
    mesh = swatch_mesh(swatch)
    paths = [write_mesh(out / f"{name}.vtu", mesh)]
    if render:
        paths.append(render_swatch(swatch, out / f"{name}.png", mesh=mesh, view=view,
                                   window_size=window_size))
    return paths
