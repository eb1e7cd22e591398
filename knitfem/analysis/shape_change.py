"""How far a swatch's shape changed between two states, rigid motion taken out.

A free-floating swatch may drift and turn as a whole while it relaxes, so node
moves alone cannot tell a sliding or snapping swatch (its shape changes) from
one that only drifts.  Here the first state is carried onto the second by the
best rigid motion (least squares over the nodes: scipy's ``align_vectors``, the
Kabsch solution) and what remains is the change of shape.  Pure functions of
node positions (n, 3), in the positions' length unit (mm in knitfem's scenes).
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass
class ShapeChange:
    median: float          # median node move after the rigid alignment (length)
    max: float             # largest node move after it
    rotation_deg: float    # the rigid rotation taken out
    shift: float           # the centroid's move (length)


def _positions(x, name):
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 3:
        raise ValueError(f"{name} must be node positions of shape (n >= 3, 3), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be finite")
    return x


def rigid_fit(x_from, x_to):
    """The rigid motion that best carries ``x_from`` onto ``x_to`` (same nodes,
    same order), x -> rotation (x - c_from) + c_to: (scipy ``Rotation``,
    c_from, c_to), the centroids."""
    a, b = _positions(x_from, "x_from"), _positions(x_to, "x_to")
    if a.shape != b.shape:
        raise ValueError(f"x_from and x_to must hold the same nodes, got {a.shape} and {b.shape}")
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    rotation, _ = Rotation.align_vectors(b - cb, a - ca)
    return rotation, ca, cb


def shape_change(x_from, x_to):
    """The node moves from ``x_from`` to ``x_to`` left after the rigid motion
    that best carries one onto the other (same nodes, same order)."""
    rotation, ca, cb = rigid_fit(x_from, x_to)
    a, b = np.asarray(x_from, float), np.asarray(x_to, float)
    moves = np.linalg.norm(rotation.apply(a - ca) + cb - b, axis=1)
    return ShapeChange(float(np.median(moves)), float(moves.max()),
                       float(np.degrees(rotation.magnitude())), float(np.linalg.norm(cb - ca)))


def principal_extents(x):
    """The swatch's extents along its principal axes, largest first (length):
    its size independent of how it lies."""
    x = _positions(x, "x")
    centred = x - x.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    along = centred @ axes.T
    return tuple(sorted((float(v) for v in along.max(axis=0) - along.min(axis=0)), reverse=True))
