"""Rod configurations as VTK unstructured grids (meshio), readable in ParaView.

Each node is a point, each element a ``line`` cell (meshio cannot write
``polyline``).  Point data: the directors d1, d2, d3, the twist K1 and the
curvature |(K2, K3)| (averages of the adjacent elements); cell data: the
material strains Gamma and K, and the rod id.  With contact on, also the
nodal contact force (point data ``contact_force``) and per element the
smallest gap capped at the law's reach g0 (``contact_gap``) and whether it
touches (``contact_active``).  A branch or load history is a ``.pvd``
collection of ``.vtu`` files.
"""
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .atomic import atomic_path, write_text


def beam_mesh(model, state, **extra_point_data):
    """meshio.Mesh of a :class:`knitfem.beam.BeamModel` state."""
    asm = model.assembly
    frames = state.frames
    gamma, kappa, _ = asm.strains(state.x, state.q)
    a, b = asm.elements
    count = np.bincount(np.concatenate([a, b]), minlength=asm.n_nodes)

    def at_nodes(values):
        total = np.bincount(a, values, asm.n_nodes) + np.bincount(b, values, asm.n_nodes)
        return total / np.maximum(count, 1)

    point_data = {"d1": frames[:, :, 0], "d2": frames[:, :, 1], "d3": frames[:, :, 2],
                  "twist": at_nodes(kappa[:, 0]),
                  "curvature": at_nodes(np.linalg.norm(kappa[:, 1:], axis=1))}
    point_data.update({k: np.asarray(v) for k, v in extra_point_data.items()})
    cell_data = {"gamma": [gamma], "kappa": [kappa], "rod": [asm.rod_of_element.astype(np.int32)]}
    contact = model.contact_model
    if contact is not None:
        _, fc, _, _ = contact.forces(state.x, tangent=False, q=state.q)
        gap = contact.report.segment_gap
        point_data["contact_force"] = -fc.reshape(-1, 6)[:, :3]
        cell_data["contact_gap"] = [gap]
        cell_data["contact_active"] = [(gap < contact.segments.law.g0).astype(np.int32)]
    return meshio.Mesh(state.x, [("line", asm.elements.T.astype(np.int64))],
                       point_data=point_data, cell_data=cell_data)


def curve_mesh(curves, point_data=None, cell_data=None):
    """meshio.Mesh of polylines: ``curves`` a list of (n_k, 3) arrays, one line
    cell per consecutive pair; point_data/cell_data: name -> list of per-curve
    arrays (n_k, ...) / (n_k - 1, ...)."""
    points = np.concatenate(curves)
    start = np.concatenate([[0], np.cumsum([len(c) for c in curves])])
    cells = np.concatenate([np.stack([np.arange(a, b - 1), np.arange(a + 1, b)], axis=1)
                            for a, b in zip(start[:-1], start[1:])])
    pdata = {k: np.concatenate(v) for k, v in (point_data or {}).items()}
    cdata = {k: [np.concatenate(v)] for k, v in (cell_data or {}).items()}
    return meshio.Mesh(points, [("line", cells.astype(np.int64))], point_data=pdata,
                       cell_data=cdata)


def write_mesh(path, mesh):
    """Write a meshio mesh atomically, creating the folder; returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        mesh.write(tmp, file_format="vtu" if path.suffix == ".vtu" else None)
    return path


def write_beam_state(path, model, state, **extra_point_data):
    """Write one state to ``path`` (.vtu); returns the path."""
    return write_mesh(path, beam_mesh(model, state, **extra_point_data))


def write_series(path, files, times):
    """A ParaView ``.pvd`` collection listing ``files`` (.vtu) at ``times``."""
    path = Path(path)
    rows = "\n".join(
        f'    <DataSet timestep="{float(t):.9g}" part="0" file={quoteattr(Path(f).name)}/>'
        for f, t in zip(files, times))
    return write_text(path, '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                      f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")
