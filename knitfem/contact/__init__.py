"""Penalty yarn-yarn contact between centreline segments (knows segments, not beams).

``SegmentContact`` runs the broad phase (cKDTree), the Gauss-point-to-curve
narrow phase and the penalty law, and returns per (slave, master) pair
18-vectors and 18 x 18 consistent tangents in the slots of six segment ends
(the slave's two, the master's two and its neighbours' far ends, which shape
the smooth master curve); a model scatters them into its own unknowns.
"""
from dataclasses import dataclass, field

import numpy as np

from .broad import CandidateList, brute_force_pairs, candidate_pairs
from .law import DEFAULT_FACTOR, DEFAULT_REGULARISATION, PenaltyLaw
from .master import bulge, neighbours
from .friction import anchors, carry_slip, friction_forces
from .narrow import pair_forces

__all__ = ["ContactReport", "PenaltyLaw", "SegmentContact", "brute_force_pairs",
           "candidate_pairs", "pair_forces", "DEFAULT_FACTOR", "DEFAULT_REGULARISATION"]


@dataclass
class ContactReport:
    """After a solve: candidate and active pairs, the smallest gap (negative =
    penetration), the largest penetration as a fraction of the summed radii,
    the total normal force; per segment the smallest gap, capped at the
    law's reach g0 (>= g0: no contact); the normal force taken back at the
    maxima of the distance where two contacts along one master yarn overlap
    (already subtracted from the total, see :mod:`knitfem.contact.narrow`)."""
    candidates: int
    active_pairs: int
    min_gap: float
    max_penetration: float
    max_penetration_ratio: float
    total_normal_force: float
    segment_gap: np.ndarray = field(default=None, repr=False)
    overlap_force: float = 0.0


def slave_rank(rod, length=None):
    """Slave priority of every segment: yarns ordered by mean element length
    (finer first), then by id; all segments of a yarn share its rank."""
    rods = np.unique(rod)
    mean = np.array([0.0 if length is None else np.mean(length[rod == r]) for r in rods])
    order = np.lexsort((rods, mean))
    rank_of = np.empty(len(rods), np.int64)
    rank_of[order] = np.arange(len(rods))
    return rank_of[np.searchsorted(rods, rod)]


class SegmentContact:
    """Contact among segments (x0[i], x1[i]) of radius radius[i] on rods rod[i],
    whose midpoints sit at arclength s_mid[i] along their rod.

    exclude : arclength below which segments of one rod are neighbours (default
    twice the largest diameter).  per_diameter : Gauss points per yarn diameter.
    """

    def __init__(self, law, radius, rod, s_mid, exclude=None, per_diameter=6):
        if not isinstance(law, PenaltyLaw):
            raise ValueError("law must be a knitfem.contact.PenaltyLaw")
        self.law = law
        self.radius = np.asarray(radius, dtype=float)
        if not np.all(np.isfinite(self.radius) & (self.radius > 0)):
            raise ValueError("segment radii must be finite and in (0, inf) (a rod section "
                             "needs a radius for contact)")
        self.rod = np.asarray(rod)
        self.s_mid = np.asarray(s_mid, dtype=float)
        self.rank = slave_rank(self.rod, length=None)
        self.exclude = 4.0 * self.radius.max() if exclude is None else float(exclude)
        self.per_diameter = float(per_diameter)
        self._ranked_by = None
        self._order = np.lexsort((self.s_mid, self.rod))
        # the broad phase kept while no segment moved half a yarn radius (a
        # wider skin keeps it longer but filters more pairs at every call:
        # 25 x 35 swatch, 1 r: 33 ms a call, 215 ms a search; 2 r: 57 / 353 ms)
        self.candidates = CandidateList(self.radius.max())

    def evaluate(self, x0, x1, tangent=True, length=None, previous=None, damping_rate=0.0):
        """(energy, the (slave, master) pairs carrying force (k, 2), their slots'
        segment ends (k, 6) (2 i + e: end e of segment i), gradients (k, 18),
        Hessians (k, 18, 18) or None, ContactReport).  previous = (x0, x1) at
        the start of an increment and damping_rate = c/dt add normal damping
        (see :mod:`knitfem.contact.narrow`)."""
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(x1))):
            raise ValueError("segment ends contain NaN or infinite values")
        prev, nxt = neighbours(x0, x1, self.rod, self.s_mid, self._order)
        bulges = bulge(x0, x1, prev, nxt)
        pairs = self.candidates(x0, x1, self.radius, self.rod, self.s_mid, self.law.g0,
                                self.exclude, bulges)
        if pairs.shape[0] == 0:
            return 0.0, pairs, np.zeros((0, 6), np.int64), np.zeros((0, 18)), \
                (np.zeros((0, 18, 18)) if tangent else None), \
                ContactReport(0, 0, np.inf, 0.0, 0.0, 0.0, np.full(len(x0), self.law.g0))
        if length is not None and self._ranked_by is not length:
            self.rank, self._ranked_by = slave_rank(self.rod, length), length
        energy, active, ends, grads, hess, stats, seg_gap = pair_forces(
            x0, x1, self.radius, pairs, self.law, self.per_diameter, 4, tangent, length,
            self.rank, previous, damping_rate, prev, nxt, bulges)
        penetration = max(0.0, -stats[0])
        R = 2.0 * self.radius.max()
        return energy, active, ends, grads, hess, ContactReport(
            int(pairs.shape[0]), int(active.shape[0]), float(stats[0]), penetration,
            penetration / R, float(stats[2]), np.minimum(seg_gap, self.law.g0), float(stats[3]))

    def friction_anchors(self, x0, x1, mu, length=None):
        """Friction anchors (:func:`knitfem.contact.friction.anchors`) of every
        Gauss point in contact at the segment ends x0, x1, slip measured from
        there (the lever arms need the distance of the same state)."""
        prev, nxt = neighbours(x0, x1, self.rod, self.s_mid, self._order)
        bulges = bulge(x0, x1, prev, nxt)
        pairs = self.candidates(x0, x1, self.radius, self.rod, self.s_mid, self.law.g0,
                                self.exclude, bulges)
        if length is not None and self._ranked_by is not length:
            self.rank, self._ranked_by = slave_rank(self.rod, length), length
        points = pair_forces(x0, x1, self.radius, pairs, self.law, self.per_diameter, 4, False,
                             length, self.rank, None, 0.0, prev, nxt, bulges, record=True)[-1]
        return anchors(points, x0, x1, prev, nxt, mu, self.radius)
