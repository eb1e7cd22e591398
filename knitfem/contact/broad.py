"""Broad phase: which segment pairs can touch.

Each segment (x0, x1) with radius r gets a bounding sphere about its midpoint
of radius |x1 - x0|/2 + r + g0/2 (+ how far its contact curve may bulge out
of the chord, see :func:`knitfem.contact.narrow.bulge`); two segments are candidates when their
spheres overlap.  A cKDTree over the midpoints finds them in O(n log n); far
pairs are never looked at, and a scene without candidates pays one query.
Neighbours along one rod (closer than ``exclude`` in arclength) are dropped:
they are joined, not in contact.
"""
import numpy as np
from scipy.spatial import cKDTree


def bounding_spheres(x0, x1, radius, g0, bulge=0.0):
    """Centres (n, 3) and radii (n,) of the segments' bounding spheres."""
    return 0.5 * (x0 + x1), 0.5 * np.linalg.norm(x1 - x0, axis=1) + radius + 0.5 * g0 + bulge


def _keep(pairs, centre, rho, rod, s_mid, exclude):
    a, b = pairs[:, 0], pairs[:, 1]
    overlap = np.linalg.norm(centre[a] - centre[b], axis=1) < rho[a] + rho[b]
    apart = (rod[a] != rod[b]) | (np.abs(s_mid[a] - s_mid[b]) > exclude)
    return pairs[overlap & apart]


def candidate_pairs(x0, x1, radius, rod, s_mid, g0, exclude, bulge=0.0):
    """Index pairs (m, 2), i < j, of segments whose bounding spheres overlap.

    x0, x1 : (n, 3) segment ends; radius : (n,); rod : (n,) rod id;
    s_mid : (n,) arclength of the midpoints along their rod; g0 : regularisation
    gap of the law; exclude : arclength below which two segments of one rod
    are neighbours, not contacts; bulge : (n,) or scalar, how far each
    segment's contact curve may leave its chord.
    """
    if x0.shape[0] < 2:
        return np.empty((0, 2), dtype=np.int64)
    centre, rho = bounding_spheres(x0, x1, radius, g0, bulge)
    pairs = cKDTree(centre).query_pairs(2.0 * rho.max(), output_type="ndarray")
    if pairs.shape[0] == 0:
        return pairs.astype(np.int64)
    return _keep(pairs, centre, rho, rod, s_mid, exclude).astype(np.int64)


def brute_force_pairs(x0, x1, radius, rod, s_mid, g0, exclude, bulge=0.0):
    """The same set by checking every pair (O(n^2), for tests)."""
    centre, rho = bounding_spheres(x0, x1, radius, g0, bulge)
    i, j = np.triu_indices(x0.shape[0], 1)
    return _keep(np.stack([i, j], axis=1), centre, rho, rod, s_mid, exclude)
