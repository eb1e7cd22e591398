"""Uniform cubic B-spline yarn centrelines (Kaldor et al. 2008).

A yarn of N segments has N + 3 control points q (N+3, 3) (open) or N (closed,
indices wrap).  On segment i, u in [0, 1]:

    r(u) = sum_{j=0..3} q[i + j] B_j(u),   B = (1/6) [(1-u)^3, 3u^3 - 6u^2 + 4,
                                               -3u^3 + 3u^2 + 3u + 1, u^3]

The curve is C2; r(0) of segment i is (q_i + 4 q_{i+1} + q_{i+2}) / 6 and
r'(0) = (q_{i+2} - q_i) / 2.  Everything here is geometry: evaluation and
least-squares fitting, shared by the knit geometry and the yarn mechanics.
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

_M = np.array([[-1.0, 3.0, -3.0, 1.0],        # B_j(u) = sum_k M[k, j] u^(3-k) / 6
               [3.0, -6.0, 3.0, 0.0],
               [-3.0, 0.0, 3.0, 0.0],
               [1.0, 4.0, 1.0, 0.0]]) / 6.0


def basis(u, derivative=0):
    """B_j^(derivative)(u) for u (m,) -> (m, 4)."""
    u = np.asarray(u, dtype=float)
    powers = np.stack([u**3, u**2, u, np.ones_like(u)], axis=-1)
    if derivative == 1:
        powers = np.stack([3 * u**2, 2 * u, np.ones_like(u), np.zeros_like(u)], axis=-1)
    elif derivative == 2:
        powers = np.stack([6 * u, 2 * np.ones_like(u), np.zeros_like(u), np.zeros_like(u)],
                          axis=-1)
    elif derivative != 0:
        raise ValueError(f"derivative must be 0, 1 or 2, got {derivative!r}")
    return powers @ _M


def segment_indices(segments, closed=False):
    """Control-point indices (segments, 4) of each segment."""
    i = np.arange(segments)[:, None] + np.arange(4)[None, :]
    return i % segments if closed else i


def evaluate(q, u_per_segment, closed=False, derivative=0):
    """Points (segments, m, 3) at parameters u (m,) on every segment."""
    q = np.asarray(q, dtype=float)
    segments = q.shape[0] if closed else q.shape[0] - 3
    B = basis(u_per_segment, derivative)                      # (m, 4)
    return np.einsum("mj,sjk->smk", B, q[segment_indices(segments, closed)])


def fit(points, segments, closed=False):
    """Least-squares control points (segments+3 or segments, 3) of a B-spline
    through ``points`` (n, 3), parametrised by chord length, uniform knots."""
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise ValueError("points must be a finite (n, 3) array")
    if int(segments) != segments or segments < 1:
        raise ValueError(f"segments must be an integer >= 1, got {segments!r}")
    segments = int(segments)
    n_ctrl = segments if closed else segments + 3
    if points.shape[0] < n_ctrl:
        raise ValueError(f"need at least {n_ctrl} points to fit {segments} segments, "
                         f"got {points.shape[0]}")
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    t = chord / chord[-1] * segments
    seg = np.minimum(t.astype(int), segments - 1)
    B = basis(t - seg)
    idx = segment_indices(segments, closed)[seg]
    # banded collocation matrix (4 entries a row): sparse least squares
    A = sparse.csr_matrix((B.ravel(), (np.repeat(np.arange(points.shape[0]), 4), idx.ravel())),
                          shape=(points.shape[0], n_ctrl))
    N = (A.T @ A).tocsc()
    if np.any(np.abs(N.diagonal()) == 0):
        raise ValueError(f"points leave some of the {segments} segments empty: give more "
                         "points or fewer segments")
    return np.atleast_2d(splinalg.spsolve(N, A.T @ points)).reshape(n_ctrl, 3)
