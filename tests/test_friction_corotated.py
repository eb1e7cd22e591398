"""Co-rotated friction (``corotated``): the slip measured in the master yarn's
frame turned since the anchor, so the friction forces turn with the yarns
within a round (knitfem.contact.friction)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from knitfem.beam.rotation import quat_from_rotation, quat_multiply
from knitfem.contact.friction import friction_forces, slips

from test_friction import _swatch_touching


@pytest.fixture(scope="module")
def pressed():
    """The 3 x 3 swatch pressed at lam 0.3, friction anchored (carried slips)
    and then turned and moved a little, so the anchors hold slips and turns."""
    model, state = _swatch_touching()
    contact = model.contact_model
    contact.corotated = True
    contact.anchor_friction(state.x, state.q)
    rng = np.random.default_rng(3)
    moved = model.retract(state, 2e-3 * rng.normal(size=model.assembly.n_dofs))
    return model, state, moved


def _friction(model, s, tangent=False):
    c = model.contact_model
    a, b = c.nodes[:, 0], c.nodes[:, 1]
    return friction_forces(c.anchors, s.x[a], s.x[b], c.slip, tangent, c._turns(s.q)[1],
                           corotated=True)


def _rigid(model, s, rotvec, shift):
    R = Rotation.from_rotvec(rotvec)
    x = R.apply(s.x - s.x.mean(axis=0)) + s.x.mean(axis=0) + shift
    q = quat_multiply(np.broadcast_to(quat_from_rotation(R), s.q.shape), s.q)
    return s._replace(x=x, q=q) if hasattr(s, "_replace") else type(s)(x, q)


def test_corotated_slip_is_blind_to_rigid_motions_of_any_size(pressed):
    """A rigid rotation of the whole swatch by 0.48 rad (and a shift) leaves
    every co-rotated slip's length unchanged to 1e-8 of the stick slip
    (measured 1.6e-13; with the nodes' rotation vectors interpolated
    linearly along a segment instead of the geodesic, 3.7e-5); the slip in
    the anchor's fixed tangent plane changes by 6 stick slips (its rotation
    term is first order)."""
    model, _, s = pressed
    c = model.contact_model
    a, b = c.nodes[:, 0], c.nodes[:, 1]
    t = _rigid(model, s, np.array([0.3, -0.2, 0.35]), np.array([1.0, 2.0, -0.5]))
    for corotated, small in ((True, True), (False, False)):
        u0 = np.linalg.norm(slips(c.anchors, s.x[a], s.x[b], c._turns(s.q)[1], corotated), axis=1)
        u1 = np.linalg.norm(slips(c.anchors, t.x[a], t.x[b], c._turns(t.q)[1], corotated), axis=1)
        change = np.max(np.abs(u1 - u0)) / c.slip
        assert (change <= 1e-8) if small else (change >= 1.0)


def test_corotated_slip_starts_where_the_fixed_plane_slip_does(pressed):
    """To first order in the turns both slips agree (the fixed plane's is the
    co-rotated one's linearisation): turns of 1e-4 rad give slips within
    a few 1e-8 of each other."""
    model, state, _ = pressed
    c = model.contact_model
    a, b = c.nodes[:, 0], c.nodes[:, 1]
    rng = np.random.default_rng(4)
    s = model.retract(state, 1e-4 * rng.normal(size=model.assembly.n_dofs))
    th = c._turns(s.q)[1]
    u_co = slips(c.anchors, s.x[a], s.x[b], th, True)
    u_fix = slips(c.anchors, s.x[a], s.x[b], th, False)
    assert np.max(np.abs(u_co - u_fix)) <= 1e-6 * c.slip / 1e-3 + 5e-8


def test_corotated_gradient_is_exact_and_the_hessian_close(pressed):
    """Central differences of the friction energy along mixed directions
    (positions and spatial turns) equal the gradient to 1e-7; the Hessian
    agrees with differences of the gradient to 1e-3 (measured 9e-5 .. 3e-4
    with frames turned ~2e-3 since the anchors, ten times less at ten times
    smaller turns: what is left out is of order |g| times the turn; the
    Gauss-Newton part J^T H3 J alone was off by 6e-4 .. 3e-3)."""
    from knitfem.beam.assembly import block_matrix, block_vector
    model, _, s = pressed
    c = model.contact_model
    n = model.assembly.n_dofs
    friction = c.blocks(s.x, s.q, True)[1][1:]      # J^T H3 J and the geometric part
    assert len(friction) == 2 and friction[0][3] is None and friction[1][3] is True
    G = sum(block_vector(dofs, g, n) for dofs, g, _, _ in friction)
    H = sum(block_matrix(dofs, hess, n) for dofs, _, hess, _ in friction)

    def gradient(t):
        return sum(block_vector(dofs, g, n) for dofs, g, _, _ in c.blocks(t.x, t.q, False)[1][1:])
    rng = np.random.default_rng(5)
    h = 1e-6
    for _ in range(3):
        d = rng.normal(size=n)
        d /= np.linalg.norm(d)
        ep = _friction(model, model.retract(s, h * d))[0]
        em = _friction(model, model.retract(s, -h * d))[0]
        assert abs((ep - em) / (2 * h) - G @ d) <= 1e-7 * max(1.0, np.abs(G).sum())
        gp, gm = gradient(model.retract(s, h * d)), gradient(model.retract(s, -h * d))
        assert np.linalg.norm((gp - gm) / (2 * h) - H @ d) <= 5e-3 * np.linalg.norm(H @ d)


def test_corotated_friction_depends_on_the_turns_not_on_their_rotation_vectors(pressed):
    """Where a frame passes a half turn since its anchor its rotation vector
    wraps (pi a -> -pi a); the linearly interpolated rotation vectors then
    made the friction energy jump (by 0.02 on a 3 x 4 swatch at alpha 0.2,
    which stalled on it, mu -> 1e7).  The geodesic interpolation depends on
    the rotations only: every turn replaced by its other rotation vector
    theta - 2 pi theta/|theta| (the same rotation) leaves the energy and the
    gradient unchanged to 1e-9."""
    model, _, s = pressed
    c = model.contact_model
    a, b = c.nodes[:, 0], c.nodes[:, 1]
    th = c._turns(s.q)[1]
    size = np.linalg.norm(th, axis=-1, keepdims=True)
    other = th - 2.0 * np.pi * th / np.maximum(size, 1e-300)
    E0, g0, _ = friction_forces(c.anchors, s.x[a], s.x[b], c.slip, False, th, corotated=True)
    E1, g1, _ = friction_forces(c.anchors, s.x[a], s.x[b], c.slip, False, other, corotated=True)
    assert E0 > 0 and abs(E1 - E0) <= 1e-9 * E0
    assert np.abs(g1 - g0).max() <= 1e-9 * np.abs(g0).max()
    fixed = friction_forces(c.anchors, s.x[a], s.x[b], c.slip, False, other)[0]
    assert abs(fixed - E0) > 1e-3 * E0            # the fixed-plane friction's rotation term


def _geometric_by_einsum(g3, pieces, s):
    """The batched-einsum formulation of corotated_geometric (the code before
    its numba kernel), kept as the reference the kernel must reproduce."""
    from knitfem.contact.corotated import hat
    R_m, v, m, arm_s, C = pieces
    k = len(g3)
    G = np.einsum("kij,kj->ki", R_m, g3)
    eye = np.eye(3)[None]
    Gv, Gm = np.sum(G * v, axis=1)[:, None, None], np.sum(G * m, axis=1)[:, None, None]
    outer = lambda p, q: p[:, :, None] * q[:, None, :]      # noqa: E731
    phi = np.zeros((k, 2, 3, 2, 3))
    phi[:, 0, :, 0, :] = -arm_s[:, None, None] * (0.5 * (outer(G, m) + outer(m, G)) - Gm * eye)
    phi[:, 1, :, 1, :] = 0.5 * (outer(G, v) + outer(v, G)) - Gv * eye
    phi[:, 1, :, 0, :] = arm_s[:, None, None] * (outer(m, G) - Gm * eye)
    phi[:, 0, :, 1, :] = np.swapaxes(phi[:, 1, :, 0, :], 1, 2)
    side = np.array([0, 0, 1, 1])
    K = np.zeros((k, 10, 3, 10, 3))
    K[:, 6:, :, 6:, :] = np.einsum("kbji,kbjcl,kclm->kbicm", C, phi[:, side][:, :, :, side], C)
    tm = np.einsum("kbji,kjl,ka->kbial", C[:, 2:], hat(G), s)
    K[:, 8:, :, :6, :] = tm
    K[:, :6, :, 8:, :] = tm.transpose(0, 3, 4, 1, 2)
    return K.reshape(k, 30, 30)


def test_geometric_kernel_reproduces_the_einsum_formulation():
    from knitfem.contact.corotated import corotated_geometric
    rng = np.random.default_rng(7)
    k = 57
    R_m = Rotation.random(k, random_state=3).as_matrix()
    pieces = (R_m, rng.normal(size=(k, 3)), rng.normal(size=(k, 3)), rng.uniform(0.1, 1, k),
              rng.normal(size=(k, 4, 3, 3)))
    g3, s = rng.normal(size=(k, 3)), rng.uniform(0, 1, (k, 6))
    K = corotated_geometric(g3, pieces, s)
    ref = _geometric_by_einsum(g3, pieces, s)
    assert K.shape == (k, 30, 30)
    assert np.max(np.abs(K - ref)) <= 1e-13 * np.max(np.abs(ref))
    assert np.array_equal(K == 0.0, ref == 0.0)       # the same blocks, nothing else
