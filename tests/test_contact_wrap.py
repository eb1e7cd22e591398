"""Contact with a master yarn that bends around the slave point: every local
minimum of the distance pushes, the maxima between them are subtracted, so
the contact energy is continuous with a continuous gradient where two minima
tie or where a minimum is born or dies with a maximum (the old rule, the
nearest point of each stretch only, put a kink there that 2-cycled Newton)."""
import numpy as np
import pytest
from scipy.integrate import quad

from knitfem.contact import PenaltyLaw, candidate_pairs
from knitfem.contact.master import bulge, critical_points, neighbours
from knitfem.contact.narrow import pair_forces

R = 0.4                                            # yarn radius: contact at 0.8


def test_every_critical_point_of_the_distance_is_found(rng):
    """The critical points of the distance from a point to a random cubic on
    (0, 1] are the real roots of the quintic F' there (numpy's companion
    matrix), to 1e-9, none missed or doubled, minima and maxima alternating."""
    D, roots, kinds = np.empty((6, 6)), np.empty(6), np.empty(6, np.int64)
    for _ in range(2000):
        C, p = rng.normal(size=(4, 3)), rng.normal(size=3)
        n, g0, g1 = critical_points(p, C, np.nan, D, roots, kinds)
        r = np.roots(D[0, ::-1])
        r = np.sort(r[(np.abs(r.imag) < 1e-9) & (r.real > 0) & (r.real <= 1)].real)
        assert len(r) == n and np.allclose(r, roots[:n], atol=1e-9)
        assert np.all(kinds[:n][1:] == -kinds[:n][:-1])
        assert n == 0 or kinds[0] == (1 if g0 < 0 else -1)


def _scene(master_points, slave_xy, pieces=20):
    """One master polyline in the x-y plane and a slave yarn of length 1
    along z through slave_xy, in ``pieces`` segments."""
    m = len(master_points) - 1
    z = np.linspace(-0.5, 0.5, pieces + 1)
    slave = np.stack([np.full_like(z, slave_xy[0]), np.full_like(z, slave_xy[1]), z], 1)
    x0 = np.vstack([master_points[:-1], slave[:-1]])
    x1 = np.vstack([master_points[1:], slave[1:]])
    rod = np.array([0] * m + [1] * pieces)
    h = np.linalg.norm(x1 - x0, axis=1)
    s_mid = np.r_[np.cumsum(h[:m]) - 0.5 * h[:m], np.cumsum(h[m:]) - 0.5 * h[m:]]
    return x0, x1, rod, s_mid


def _energy_and_force(x0, x1, rod, s_mid, law, tangent=False):
    radius = np.full(len(rod), R)
    prev, nxt = neighbours(x0, x1, rod, s_mid)
    b = bulge(x0, x1, prev, nxt)
    pairs = candidate_pairs(x0, x1, radius, rod, s_mid, law.g0, 2.0, b)
    out = pair_forces(x0, x1, radius, pairs, law, tangent=tangent, rank=1 - rod, prev=prev,
                      nxt=nxt, bulges=b)
    energy, _, ends, grads = out[:4]
    on_slave = rod[ends // 2] == 1
    force = -np.sum(grads.reshape(-1, 6, 3) * on_slave[:, :, None], axis=(0, 1))
    return energy, force, out


def _hairpin(rho, legs=3.0, h=0.1):
    """A hairpin: half circle of radius rho about the origin (apex at y = -rho),
    straight legs up to y = legs, points about h apart."""
    arc = np.linspace(np.pi, 2 * np.pi, int(np.ceil(np.pi * rho / h)) + 1)
    leg = np.linspace(0.0, legs, int(np.ceil(legs / h)) + 1)[1:]
    pts = [(-rho, y, 0.0) for y in leg[::-1]] + [(rho * np.cos(a), rho * np.sin(a), 0.0)
                                                  for a in arc] + [(rho, y, 0.0) for y in leg]
    return np.array(pts)


def _crossing(law, h):
    """Energy and force of a straight yarn crossing another at right angles,
    centrelines h apart: int phi(sqrt(z^2 + h^2) - 2R) dz and
    int f(..) h / sqrt(z^2 + h^2) dz."""
    reach = np.sqrt(max((2 * R + law.g0) ** 2 - h * h, 0.0))
    e = quad(lambda z: law.energy(np.hypot(z, h) - 2 * R), -reach, reach, epsabs=0,
             epsrel=1e-12, limit=200)[0]
    f = quad(lambda z: law.force(np.hypot(z, h) - 2 * R) * h / np.hypot(z, h), -reach, reach,
             epsabs=0, epsrel=1e-12, limit=200)[0]
    return e, f


@pytest.mark.parametrize("dx", [0.0, 1e-3, -0.02])
def test_yarn_between_the_legs_of_a_hairpin_is_pushed_by_both(dx):
    """A slave yarn crossing the plane of a hairpin between its straight legs
    (half spacing 0.79, the contact distance 0.8; the bend 1.5 away, out of
    reach): energy and force are those of two crossings, at 0.79 + dx and
    0.79 - dx (closed-form integrals; 1e-5, and 1e-4 of one leg's force: the
    slave's Gauss quadrature), also where the legs are equally near."""
    law = PenaltyLaw(1000.0, 0.04)
    energy, force, _ = _energy_and_force(*_scene(_hairpin(0.79), (dx, 1.5)), law)
    (e_left, f_left), (e_right, f_right) = _crossing(law, 0.79 + dx), _crossing(law, 0.79 - dx)
    assert abs(energy / (e_left + e_right) - 1) < 1e-5
    assert abs(force[0] - (f_left - f_right)) < 1e-4 * f_right
    assert abs(force[1]) < 1e-9 * f_right and abs(force[2]) < 1e-9 * f_right


def _parabola(rho=0.7, half=2.0, h=0.1):
    """y = x^2 / (2 rho): curvature radius rho at the apex, growing away from it."""
    x = np.linspace(-half, half, int(round(2 * half / h)) + 1)
    return np.stack([x, x * x / (2 * rho), 0 * x], 1)


def test_contact_force_is_continuous_where_minima_tie_and_are_born():
    """A slave yarn slid across the inside of a parabolic bend (apex radius
    0.7 < 0.8, the contact distance), 0.78 above its apex: on the way a
    minimum of the distance is born with a maximum (x = -0.0147), the two
    minima tie (x = 0) and one dies again.  The force is the energy's
    derivative (central differences, 1e-6 of its size) and continuous: the
    largest change between neighbouring samples shrinks as the samples
    get denser (by 0.6 for 4 x denser; near the births it changes like the
    square root of the distance, as the critical points do; a jump would
    stay: the nearest point alone jumped from +f to -f at the tie)."""
    law = PenaltyLaw(1000.0, 0.04)
    master = _parabola()

    def force(x):
        return _energy_and_force(*_scene(master, (x, 0.78)), law)[1]

    def energy(x):
        return _energy_and_force(*_scene(master, (x, 0.78)), law)[0]
    largest = []
    for n in (201, 801):
        xs = np.linspace(-0.05, 0.05, n)
        forces = np.array([force(x) for x in xs])
        largest.append(np.linalg.norm(np.diff(forces, axis=0), axis=1).max())
    h = 1e-6
    for x, f in zip(xs[::8], forces[::8]):
        assert abs(-(energy(x + h) - energy(x - h)) / (2 * h) - f[0]) < 1e-6 * np.linalg.norm(f)
    assert largest[1] < 0.6 * largest[0]


@pytest.mark.parametrize("damping", [0.0, 10.0])
def test_tangent_holds_with_two_minima_and_a_maximum_in_reach(rng, damping):
    """Inside the parabolic bend (two minima and the maximum between them in
    reach), nodes perturbed: the contact gradient is the energy's derivative
    and the Hessian in the pairs' slots the gradient's (central differences
    along random node moves, 1e-6), also with normal damping against a
    previous state where the slave lay outside the bend's two-minima zone
    (the gap a step ago taken from that state alone: taken at the current
    parameter where a minimum had no predecessor, the tangent was off by
    6e-4 here)."""
    law = PenaltyLaw(1000.0, 0.04)
    x0, x1, rod, s_mid = _scene(_parabola(), (0.004, 0.78))
    n, m = len(rod), int(np.sum(rod == 0))
    prev, nxt = neighbours(x0, x1, rod, s_mid)
    radius, length = np.full(n, R), np.linalg.norm(x1 - x0, axis=1)
    pairs = candidate_pairs(x0, x1, radius, rod, s_mid, law.g0, 2.0, bulge(x0, x1, prev, nxt))
    start = np.where(rod == 0, np.arange(n), np.arange(n) + 1)     # node at each segment's x0
    X = np.vstack([x0[:m], x1[m - 1:m], x0[m:], x1[-1:]]) + 1e-3 * rng.normal(size=(n + 2, 3))
    Xp = X + 1e-3 * rng.normal(size=X.shape)
    Xp[m + 1:, 0] += 0.03          # a step ago the slave saw one minimum: one was born since

    def evaluate(X):
        out = pair_forces(X[start], X[start + 1], radius, pairs, law, rank=1 - rod, prev=prev,
                          nxt=nxt, length=length, previous=(Xp[start], Xp[start + 1]),
                          damping_rate=damping)
        node = start[out[2] // 2] + out[2] % 2                      # (k, 6) slot nodes
        g = np.zeros_like(X)
        np.add.at(g, node, out[3].reshape(-1, 6, 3))
        return out[0], g, out[4], node
    energy, g, hess, node = evaluate(X)
    assert hess.shape[0] >= 2
    K = np.zeros((X.size, X.size))
    dof = (3 * node[:, :, None] + np.arange(3)).reshape(-1, 18)
    for k in range(len(dof)):     # np.add.at: a slot may repeat (a master at a yarn end)
        np.add.at(K, (dof[k][:, None], dof[k][None, :]), hess[k])
    step = 1e-7
    for _ in range(3):
        v = rng.normal(size=X.shape)
        (ep, gp, _, _), (em, gm, _, _) = evaluate(X + step * v), evaluate(X - step * v)
        if damping == 0.0:              # damping stores no energy
            assert abs((ep - em) / (2 * step) - np.sum(g * v)) < 1e-6 * abs(np.sum(g * v))
        Kv = (K @ v.ravel()).reshape(X.shape)
        assert np.linalg.norm((gp - gm) / (2 * step) - Kv) < 1e-6 * np.linalg.norm(Kv)


def test_the_force_taken_back_at_maxima_is_reported():
    """ContactReport.overlap_force: > 0 inside the parabolic bend (a maximum
    of the distance within reach), 0 between the hairpin's legs (the bend out
    of reach); the net normal force is what the minima push minus it."""
    from knitfem.contact import SegmentContact
    law = PenaltyLaw(1000.0, 0.04)
    reports = []
    for points, xy in ((_parabola(), (0.004, 0.78)), (_hairpin(0.79), (0.0, 1.5))):
        x0, x1, rod, s_mid = _scene(points, xy)
        contact = SegmentContact(law, np.full(len(rod), R), rod, s_mid)
        # the finer yarn (the straight one, 0.05 per segment) is the slave
        length = np.linalg.norm(x1 - x0, axis=1)
        reports.append(contact.evaluate(x0, x1, tangent=False, length=length)[-1])
    inside, legs = reports
    assert inside.overlap_force > 0 and inside.total_normal_force > 0
    assert legs.overlap_force == 0.0 and legs.total_normal_force > 0


def test_friction_carries_each_minimum_its_own_slip():
    """A slave Gauss point between the hairpin's legs touches both (two
    anchors of one Gauss point); the legs slide 1e-4 along the slave yarn in
    opposite senses: re-anchored with the slips carried over, each leg's
    anchors hold that leg's slip (1e-8), not the other's (a key of the Gauss
    point alone gave both legs one slip, of the wrong sign for one)."""
    from knitfem.contact import SegmentContact, carry_slip
    from knitfem.contact.friction import slips
    law = PenaltyLaw(1000.0, 0.04)
    x0, x1, rod, s_mid = _scene(_hairpin(0.79), (0.0, 1.5))
    contact = SegmentContact(law, np.full(len(rod), R), rod, s_mid)
    length = np.linalg.norm(x1 - x0, axis=1)
    old = contact.friction_anchors(x0, x1, 0.3, length=length)
    assert np.max(np.unique(old.key, return_counts=True)[1]) == 2
    y0, y1 = x0.copy(), x1.copy()
    for y in (y0, y1):
        y[(rod == 0) & (y[:, 0] < 0), 2] += 1e-4
        y[(rod == 0) & (y[:, 0] > 0), 2] -= 1e-4
    before = slips(old, y0, y1)[:, 2]
    new = contact.friction_anchors(y0, y1, 0.3, length=length)
    held = slips(carry_slip(new, old, y0, y1, eps=1.0), y0, y1)[:, 2]
    for was, now in ((old.normal[:, 0] > 0, new.normal[:, 0] > 0),
                     (old.normal[:, 0] < 0, new.normal[:, 0] < 0)):
        assert now.sum() == was.sum() > 0
        assert np.allclose(np.sort(held[now]), np.sort(before[was]), rtol=0, atol=1e-8)
        assert abs(np.mean(before[was])) > 8e-5
