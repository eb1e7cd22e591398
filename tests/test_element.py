"""The element kernel: residual = energy gradient, tangent = residual derivative,
strains = their definition, objectivity."""
import numpy as np
from scipy.spatial.transform import Rotation

from knitfem.beam.element import element_forces, element_strains
from knitfem.beam.rotation import hat, quat_multiply, rotate_spatially, rotation_from_vector


def random_elements(rng, n=12, spread=1.5):
    q = rng.normal(size=(n, 4))
    qA = q / np.linalg.norm(q, axis=1, keepdims=True)
    qB = quat_multiply(rotation_from_vector(spread * rng.normal(size=(n, 3)) / 2), qA)
    qB[::3] *= -1.0                       # same rotations, other quaternion sign
    xA = rng.normal(size=(n, 3))
    xB = xA + rng.normal(size=(n, 3))
    h = rng.uniform(0.5, 2.0, n)
    data = dict(h=h, gamma0=rng.normal(size=(n, 3)), kappa0=rng.normal(size=(n, 3)),
                CN=rng.uniform(1, 3, (n, 3)), CM=rng.uniform(1, 3, (n, 3)))
    return (xA, xB, qA, qB), data


def moved(state, z, eps):
    xA, xB, qA, qB = state
    z = eps * z
    return (xA + z[:, 0:3], xB + z[:, 6:9], rotate_spatially(qA, z[:, 3:6]),
            rotate_spatially(qB, z[:, 9:12]))


def forces(state, data, tangent=True):
    return element_forces(*state, data["h"], data["gamma0"], data["kappa0"], data["CN"],
                          data["CM"], tangent)


def test_residual_is_the_energy_gradient_along_spatial_increments(rng):
    state, data = random_elements(rng)
    _, r, _ = forces(state, data)
    for _ in range(3):
        z = rng.normal(size=r.shape)
        e = 1e-6
        fd = (forces(moved(state, z, e), data)[0] - forces(moved(state, z, -e), data)[0]) / (2 * e)
        exact = np.einsum("ij,ij->i", r, z)
        assert np.max(np.abs(fd - exact)) < 1e-7 * np.max(np.abs(exact))


def test_tangent_matches_central_differences_of_the_residual(rng):
    """f (element level): large relative rotations up to ~2 rad, sign-flipped
    quaternions.  Relative error < 1e-9: central differences with step 1e-6
    resolve ~2e-10 (truncation ~h^2, round-off ~eps/h balance there); measured
    1.4e-10 ... 2.0e-10 over five random sets of elements."""
    state, data = random_elements(rng, spread=2.0)
    _, r, K = forces(state, data)
    for _ in range(3):
        z = rng.normal(size=r.shape)
        e = 1e-6
        fd = (forces(moved(state, z, e), data)[1] - forces(moved(state, z, -e), data)[1]) / (2 * e)
        exact = np.einsum("nij,nj->ni", K, z)
        assert np.linalg.norm(fd - exact) < 1e-9 * np.linalg.norm(exact)


def left_jacobian(psi):
    """V(psi) = integral_0^1 exp(s hat(psi)) ds (closed form)."""
    th = np.linalg.norm(psi)
    k = hat(psi / th)
    return np.eye(3) + (1 - np.cos(th)) / th * k + (th - np.sin(th)) / th * k @ k


def test_strains_are_log_of_relative_rotation_and_helicoidal_chord(rng):
    (xA, xB, qA, qB), data = random_elements(rng)
    gamma, kappa, _ = element_strains(xA, xB, qA, qB, data["h"])
    RA = Rotation.from_quat(qA, scalar_first=True)
    RB = Rotation.from_quat(qB, scalar_first=True)
    psi = (RA.inv() * RB).as_rotvec()
    assert np.allclose(kappa, psi / data["h"][:, None], atol=1e-14)
    for e in range(len(psi)):
        expected = np.linalg.solve(left_jacobian(psi[e]), RA[e].as_matrix().T @ (xB[e] - xA[e]))
        assert np.allclose(gamma[e], expected / data["h"][e], atol=1e-13)


def test_superposed_rigid_motion_leaves_strains_and_energy_unchanged(rng):
    """g (objectivity)."""
    (xA, xB, qA, qB), data = random_elements(rng)
    rot = Rotation.from_rotvec([2.0, -1.0, 2.5])        # |theta| > pi
    shift = np.array([3.0, -2.0, 7.0])
    qrot = rot.as_quat(scalar_first=True)[None]
    moved_state = (rot.apply(xA) + shift, rot.apply(xB) + shift,
                   quat_multiply(np.repeat(qrot, len(qA), 0), qA),
                   quat_multiply(np.repeat(qrot, len(qB), 0), qB))
    g1, k1, _ = element_strains(xA, xB, qA, qB, data["h"])
    g2, k2, _ = element_strains(*moved_state, data["h"])
    assert np.allclose(g1, g2, atol=1e-13) and np.allclose(k1, k2, atol=1e-13)
    E1, r1, _ = forces((xA, xB, qA, qB), data, tangent=False)
    E2, r2, _ = forces(moved_state, data, tangent=False)
    assert np.allclose(E1, E2, rtol=1e-12)
    # internal forces and moments turn with the body
    assert np.allclose(rot.apply(r1.reshape(-1, 3)), r2.reshape(-1, 3), atol=1e-11)


def test_straight_unstrained_element_has_no_force_and_a_symmetric_tangent():
    n = 3
    xA = np.zeros((n, 3))
    xB = np.tile([0.5, 0, 0], (n, 1))
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    ones = np.ones((n, 3))
    E, r, K = element_forces(xA, xB, q, q, np.full(n, 0.5), np.tile([1.0, 0, 0], (n, 1)),
                             np.zeros((n, 3)), ones, ones)
    assert np.all(E == 0) and np.all(r == 0)
    assert np.allclose(K, K.transpose(0, 2, 1), atol=1e-14)


def test_spatial_turn_inverts_rotate_spatially():
    """spatial_turn(exp(hat(theta)) q0, q0) = theta for turns below pi (1e-12)."""
    from knitfem.beam.rotation import spatial_turn
    rng = np.random.default_rng(3)
    q0 = Rotation.random(20, random_state=4).as_quat(scalar_first=True)
    theta = rng.normal(size=(20, 3))
    theta *= (rng.uniform(0.0, 3.0, size=20) / np.linalg.norm(theta, axis=1))[:, None]
    assert np.abs(spatial_turn(rotate_spatially(q0, theta), q0) - theta).max() <= 1e-12
