"""Off-screen tube renders of rod configurations with pyvista.

pyvista/VTK are imported only when a picture is asked for.  VTK goes straight
to EGL (Mesa, no display needed) unless the caller chose another window class.
"""
import os

import numpy as np


def _pyvista():
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv
    pv.OFF_SCREEN = True
    return pv


def render_rods(path, mesh, radius, *, scalars="curvature", view="iso",
                window_size=(1200, 900), title=None, camera_up=(0, 0, 1), zoom=1.0):
    """Render a meshio line mesh (see :mod:`knitfem.io.vtk`) as tubes of the
    given radius to a PNG.  ``view``: 'iso', 'xy', 'xz', 'yz' or a direction
    (3,) from which the camera looks at the scene."""
    pv = _pyvista()
    grid = pv.from_meshio(mesh).extract_surface(algorithm=None)
    # join the two-node cells into polylines so each rod is one seamless tube
    tube = grid.strip(join=True).tube(radius=radius, n_sides=24)
    plotter = pv.Plotter(off_screen=True, window_size=window_size)
    plotter.set_background("white")
    show = scalars is not None and scalars in tube.point_data
    plotter.add_mesh(tube, scalars=scalars if show else None, color=None if show else "#cc9966",
                     cmap="viridis", smooth_shading=True, show_scalar_bar=show,
                     scalar_bar_args={"title": (scalars or "").replace("_", " "),
                                      "color": "black"})
    directions = {"iso": (1, -1, 0.8), "xy": (0, 0, 1), "xz": (0, -1, 0), "yz": (1, 0, 0)}
    d = np.asarray(directions.get(view, view) if isinstance(view, str) else view, float)
    center = np.asarray(tube.center)
    plotter.camera_position = [tuple(center + d / np.linalg.norm(d) * 3 * tube.length),
                               tuple(center), camera_up]
    plotter.reset_camera()
    plotter.camera.zoom(zoom)
    if title:
        plotter.add_text(title, font_size=12, color="black")
    from ..io.atomic import atomic_path
    try:
        with atomic_path(path) as tmp:
            plotter.screenshot(str(tmp))
    finally:
        plotter.close()
    return path
