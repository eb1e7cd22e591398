"""Regularised Coulomb friction between yarns, incremental and quasi-static.

Friction acts over an *increment* from an anchor state (the last equilibrium,
or the start of a pseudo-time step) to the current state, as a dissipation
potential with lagged normal force and lagged tangent plane (the
incremental-potential treatment of Li et al. 2020, IPC):

    D(x) = sum_points  mu f_n W f0(|u_T|),
    u_T  = P_n [ (p(x) - c(t_n; x)) - (p_n - c_n) ],   P_n = I - n_n n_n^T,

for every Gauss point that was in contact at the anchor: p the slave point
(fixed xi on its chord), c(t_n; x) the master curve point at the anchor's
closest parameter t_n (fixed Catmull-Rom weights), f_n W its normal force
(line load times quadrature weight) and n_n its normal at the anchor.  u_T is
the slip of the slave point along the master since the anchor.  The Coulomb
law is regularised by the slip eps below which the contact sticks elastically
(IPC's C1 smoothing):

    f0(y) = y^2/eps - y^3/(3 eps^2) + eps/3   (y < eps),   y   (y >= eps),

so the friction force mu f_n W f0'(|u_T|) never exceeds mu f_n W (Coulomb) and
is a stiff spring 2 mu f_n W / eps in stick.

Friction acts where the yarns touch, not on the centrelines: a force pair on
the centrelines, 2r apart across the contact, would be a couple that nothing
balances (measured: a free-floating 5 x 5 swatch held at one node then
carried a reaction of 0.2 of the force scale).  The touching point divides
the centrelines' distance d at the anchor in the ratio of the radii, lever
arms a_s = r_s d / (r_s + r_m) and a_m = r_m d / (r_s + r_m) (with r_s, r_m
themselves the two surface points lie d - r_s - r_m apart inside the penalty
skin and every pair is a couple).  Rods that can turn (the beam model) pass
the rotation vectors theta of their segment ends since the anchor; the slip
of the touching point adds n x (a_s theta_s + a_m theta_m) (theta_s, theta_m
interpolated along the slave chord and the master segment), so friction also
twists and bends the yarns and the total moment balances.  D is a function of a linear map
of the positions: gradient and Hessian are exact, the Hessian is positive
semi-definite (checked by a test).  A static equilibrium reached at the end
of an increment holds the friction forces of that increment (they are part
of its residual).

**Co-rotated** (``corotated``, the fabric scene's default): the slip is
measured in the master yarn's frame at the pair, turned with it since the
anchor, between the touching material points,

    u_T = P_n [ R_m^T (r(x) - a_s R_s n) - rel0 ],

r the centrelines' relative vector, R_m, R_s the frames' rotations since the
anchor at the pair (geodesic between the segment ends: their rotation
vectors interpolated would jump where one passes a half turn), n, rel0 the
anchor's.  Exactly blind to rigid motions of any size, it agrees with the
fixed-plane slip above to first order in the turns; the fixed plane instead
holds every friction force in its anchor's tangent plane while the contacts
turn within a round (5.6 deg median on a 3 x 4 swatch at alpha 0.2), so
re-anchoring turned the forces and the rounds did not settle, and the
friction forces' net moment held free-floating swatches with reactions of
29-78 % of the force scale (10 x 35, 3 x 4, 4 x 4 at alpha 0.2).  Co-rotated,
the 3 x 4, 4 x 4 and 5 x 5 at alpha 0.2 settle, reactions ~2e-7.  Its Hessian blocks
are dense and indefinite (J^T H3 J plus the gradient times the second
derivatives of u); the PSD model keeps the first and leaves the second out.

Quasi-static paths need the friction to *persist*: re-anchoring (at a new
increment, or to update the lagged normal forces and frames within one)
carries every point's slip over (:func:`carry_slip`), clipped to the stick
radius eps, so a point keeps the friction force it had (up to mu f_n in the
slip direction) instead of starting unloaded: the elasto-plastic return
mapping of a regularised Coulomb law.  Without it each increment first loses
the friction that held the last equilibrium and must slip to rebuild it
(measured on a 5 x 5 swatch: 45-60 iterations for a 1 % homotopy step).
"""
from typing import NamedTuple

import numpy as np
from numba import njit
from .corotated import corotated_geometric, corotated_jacobian, corotated_slip, hat
from .master import shape

SLOTS = 6


class Anchors(NamedTuple):
    """Friction anchors: per point the segment ends of its six slots (k, 6)
    (2 i + e), slot coefficients s (k, 6) with p - c = sum_a s_a X_a, the
    anchor relative position rel0 (k, 3), normal (k, 3), mu f_n W (k,), a
    key (k,) naming the slave Gauss point (slave segment, Gauss index), and
    the rotation slots: segment ends (k, 4) (slave chord's two, master
    segment's two) with weights (k, 4) (interpolation times the lever arm)."""
    ends: np.ndarray
    s: np.ndarray
    rel0: np.ndarray
    normal: np.ndarray
    coefficient: np.ndarray
    key: np.ndarray
    rot_ends: np.ndarray
    rot_weights: np.ndarray


@njit(cache=True)
def _weights(t, has_prev, has_next):
    n = t.shape[0]
    out = np.empty((n, 4))
    N, dN, ddN = np.empty(4), np.empty(4), np.empty(4)
    for k in range(n):
        shape(t[k], has_prev[k], has_next[k], N, dN, ddN)
        out[k] = N
    return out


def _slot_points(ends, x0, x1):
    """Positions (k, 6, 3) of the slots' segment ends."""
    seg, end = ends // 2, ends % 2
    return np.where(end[..., None] == 0, x0[seg], x1[seg])


def anchors(points, x0, x1, prev, nxt, mu, radius):
    """Anchors of the contact points (:class:`knitfem.contact.narrow.ContactPoints`)
    at the segment ends x0, x1 (n, 3) with neighbours prev, nxt and radii
    radius (n,), for the friction coefficient mu."""
    A, B = points.slave, points.master
    has_prev, has_next = prev[B] >= 0, nxt[B] >= 0
    N = _weights(points.t, has_prev, has_next)
    ends = np.stack([2 * A, 2 * A + 1, np.where(has_prev, 2 * prev[B], 2 * B), 2 * B,
                     2 * B + 1, np.where(has_next, 2 * nxt[B] + 1, 2 * B + 1)], axis=1)
    s = np.column_stack([1.0 - points.xi, points.xi, -N])
    rel0 = np.einsum("ka,kaj->kj", s, _slot_points(ends, x0, x1))
    key = 64 * points.slave.astype(np.int64) + points.gauss
    rot_ends = np.stack([2 * A, 2 * A + 1, 2 * B, 2 * B + 1], axis=1).astype(np.int64)
    rs, rm, xi, t = radius[A], radius[B], points.xi, points.t
    # lever arms to the one point where the pair touches, dividing the
    # centrelines' distance d in the ratio of the radii: with rs and rm
    # themselves the two surface points lie d - rs - rm apart (the penalty
    # skin: +-5 % d) and every friction pair is a couple; on the relaxed
    # 25 x 35 their sum held the swatch with 14 % of the force scale
    d = np.abs(np.einsum("kj,kj->k", rel0, points.normal))
    arm = d / (rs + rm)
    rs, rm = rs * arm, rm * arm
    rot_weights = np.stack([(1.0 - xi) * rs, xi * rs, (1.0 - t) * rm, t * rm], axis=1)
    return Anchors(ends.astype(np.int64), s, rel0, points.normal.copy(),
                   mu * points.load * points.weight, key, rot_ends, rot_weights)


def slips(anchors, x0, x1, theta=None, corotated=False):
    """Tangential slips u_T (k, 3) of the anchors' surface points at the
    segment ends x0, x1, turned by theta (n, 2, 3) since the anchor (if given).
    ``corotated``: measured in the master yarn's frame at the pair (turned
    with it since the anchor) and returned in space (R_m u)."""
    a = anchors
    if corotated and theta is None:
        raise ValueError("the co-rotated friction slip needs the frames' turns theta")
    if corotated:
        r = np.einsum("ka,kaj->kj", a.s, _slot_points(a.ends, x0, x1))
        u, parts = corotated_slip(a, r, theta)
        return np.einsum("kij,kj->ki", parts[4], u)
    v = np.einsum("ka,kaj->kj", a.s, _slot_points(a.ends, x0, x1)) - a.rel0
    u = v - a.normal * np.sum(a.normal * v, axis=1, keepdims=True)
    if theta is not None:
        turn = np.einsum("kb,kbj->kj", a.rot_weights, theta[a.rot_ends // 2, a.rot_ends % 2])
        u = u + np.cross(a.normal, turn)
    return u


def _master_points(anchors, x0, x1):
    """Where each anchor's master curve point sits at the segment ends x0, x1 (k, 3)."""
    return -np.einsum("ka,kaj->kj", anchors.s[:, 2:], _slot_points(anchors.ends[:, 2:], x0, x1))


def _match(old, new, x0, x1):
    """For each anchor of ``new``, the index of the ``old`` one (non-empty) for
    the same contact and whether there is one: the same slave Gauss point
    and, where that point touches more than one master stretch or the same
    stretch at several minima of the distance, the old anchor whose master
    point lies nearest to the new one's at x0, x1 (a key of the Gauss point
    alone gave two legs of a hairpin the slip of one)."""
    order = np.argsort(old.key, kind="stable")
    keys = old.key[order]
    lo = np.searchsorted(keys, new.key, "left")
    hi = np.searchsorted(keys, new.key, "right")
    found = hi > lo
    index = order[np.minimum(lo, len(order) - 1)]
    several = np.flatnonzero(found & (hi - lo > 1))
    if len(several):
        old_at, new_at = _master_points(old, x0, x1), _master_points(new, x0, x1)
        for i in several:
            candidates = order[lo[i]:hi[i]]
            near = np.argmin(np.linalg.norm(old_at[candidates] - new_at[i], axis=1))
            index[i] = candidates[near]
    return index, found


def carry_slip(new, old, x0, x1, eps, theta=None, corotated=False):
    """``new`` anchors (made at x0, x1) holding the slips of the ``old`` ones
    at x0, x1 for the same slave Gauss points, each clipped to length eps
    (a point that slid keeps the full Coulomb force, one that stuck its
    spring): rel0 -= u, re-projected on the new tangent planes."""
    if old is None or len(old.key) == 0 or len(new.key) == 0:
        return new
    u = slips(old, x0, x1, theta, corotated)
    size = np.linalg.norm(u, axis=1)
    u *= (np.minimum(size, eps) / np.maximum(size, 1e-300))[:, None]
    index, found = _match(old, new, x0, x1)
    carried = np.where(found[:, None], u[index], 0.0)
    carried -= new.normal * np.sum(new.normal * carried, axis=1, keepdims=True)
    return new._replace(rel0=new.rel0 - carried)


def coulomb_excess(anchors, current, x0, x1, eps, theta=None, corotated=False):
    """How far the lagged friction is from Coulomb's law at x0, x1: the
    fraction of the total friction force of ``anchors`` (mu f_n W f0'(|u_T|),
    with the normal forces lagged at the anchor) that exceeds the Coulomb
    limit mu f_n W at the *current* normal forces (``current``: anchors made
    at x0, x1; a point no longer in contact has limit 0).  0 when the lagged
    normal forces have settled; the lagged rounds drive it down."""
    if anchors is None or len(anchors.key) == 0:
        return 0.0
    y = np.linalg.norm(slips(anchors, x0, x1, theta, corotated), axis=1)
    force = anchors.coefficient * np.where(y < eps, 2.0 * y / eps - y * y / eps**2, 1.0)
    limit = np.zeros_like(force)
    if len(current.key):
        index, found = _match(current, anchors, x0, x1)
        limit = np.where(found, current.coefficient[index], 0.0)
    total = float(force.sum())
    return float(np.maximum(force - limit, 0.0).sum() / total) if total > 0 else 0.0


def _f0(y, eps):
    return np.where(y < eps, y * y / eps - y**3 / (3.0 * eps * eps) + eps / 3.0, y)


class Factored(NamedTuple):
    """Hessian blocks given by factors: block k = J[k]^T H[k] J[k] (+ G[k]),
    J (k, r, w), H (k, r, r) symmetric, G (k, w, w) dense or None.  A
    friction block's J^T H J is 30 x 30 of rank <= 2 (the slip lives in the
    tangent plane): assembled from its factors by sparse products it costs a
    fraction of the dense blocks sorted into CSR; once the anchors' pattern
    is kept, the dense blocks are scattered into it, faster still
    (:func:`knitfem.beam.assembly.block_matrix`); G, the
    co-rotated friction's geometric part, is indefinite (kept apart from
    the PSD factors)."""
    J: np.ndarray
    H: np.ndarray
    G: np.ndarray = None

    def dense(self):
        """The blocks (k, w, w)."""
        base = np.einsum("kiz,kij,kjw->kzw", self.J, self.H, self.J, optimize=True)
        return base if self.G is None else base + self.G

    def apply(self, v):
        """Per block (J^T H J + G) v for block vectors v (k, w)."""
        Jv = np.einsum("kiw,kw->ki", self.J, v)
        out = np.einsum("kiw,kij,kj->kw", self.J, self.H, Jv, optimize=True)
        return out if self.G is None else out + np.einsum("kzw,kw->kz", self.G, v)


def friction_forces(anchors, x0, x1, eps, tangent=True, theta=None, factored=False,
                    corotated=False):
    """Dissipation potential, gradients (k, 18) and Hessians (k, 18, 18) in the
    anchors' translation slots, for the segment ends x0, x1 and the stick slip
    eps.  With theta (n, 2, 3), the rotation vectors of the segment ends since
    the anchor, the slots are 6 translations then 4 rotations: (k, 30) and
    (k, 30, 30) (derivatives with respect to theta).  ``factored``: the
    Hessians as :class:`Factored` (J (k, 3, w), H3 (k, 3, 3)) instead.
    ``corotated`` (with theta): the slip measured in the master yarn's frame
    turned since the anchor (:func:`slips`), so the friction forces turn with
    the yarns within a round; its Hessians are not positive semi-definite:
    J^T H3 J plus G, the gradient times the second derivatives of u
    (:func:`knitfem.contact.corotated.corotated_geometric`; ``factored``:
    in :class:`Factored`'s G)."""
    a = anchors
    k = a.ends.shape[0]
    width = 3 * SLOTS + (12 if theta is not None else 0)
    if k == 0:
        if not tangent:
            return 0.0, np.zeros((0, width)), None
        return 0.0, np.zeros((0, width)), (Factored(np.zeros((0, 3, width)), np.zeros((0, 3, 3)))
                                           if factored else np.zeros((0, width, width)))
    pieces = None
    if corotated and theta is None:
        raise ValueError("the co-rotated friction needs the frames' turns theta")
    if corotated:
        r = np.einsum("ka,kaj->kj", a.s, _slot_points(a.ends, x0, x1))
        u, J, pieces = corotated_jacobian(a, r, theta)
    else:
        u = slips(a, x0, x1, theta)
        # du/dX_a = s_a P (P drops out: g3, H3 live in the tangent plane);
        # du/dtheta_b = w_b hat(n)
        J = np.zeros((k, 3, width))
        J[:, :, :3 * SLOTS] = (a.s[:, None, :, None] * np.eye(3)[None, :, None, :]).reshape(
            k, 3, 3 * SLOTS)
        if theta is not None:
            J[:, :, 3 * SLOTS:] = (hat(a.normal)[:, :, None, :]
                                   * a.rot_weights[:, None, :, None]).reshape(k, 3, 12)
    y = np.linalg.norm(u, axis=1)
    stick = y < eps
    # f0'(y) / y, finite as y -> 0
    f1_y = np.where(stick, 2.0 / eps - y / eps**2, 1.0 / np.maximum(y, 1e-300))
    g3 = (a.coefficient * f1_y)[:, None] * u                            # d D / d u
    grads = np.einsum("kiz,ki->kz", J, g3)
    energy = float(np.sum(a.coefficient * _f0(y, eps)))
    if not tangent:
        return energy, grads, None
    P = np.eye(3)[None] - a.normal[:, :, None] * a.normal[:, None, :]
    uhat = u / np.maximum(y, 1e-300)[:, None]
    # d2 f0 / d u2 = (f0'/y) P + (f0'' - f0'/y) uhat uhat^T  (uhat lies in the plane)
    second = np.where(stick, -y / eps**2, -1.0 / np.maximum(y, 1e-300))
    H3 = a.coefficient[:, None, None] * (f1_y[:, None, None] * P + second[:, None, None]
                                         * uhat[:, :, None] * uhat[:, None, :])
    hess = Factored(J, H3, None if pieces is None else corotated_geometric(g3, pieces, a.s))
    return energy, grads, (hess if factored else hess.dense())
