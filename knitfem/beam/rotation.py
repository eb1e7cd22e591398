"""Finite rotations as unit quaternions: the numpy API and the numba kernels.

Convention: a quaternion is ``(w, x, y, z)`` with the scalar first, arrays have
shape ``(n, 4)``; rotation vectors and 3-vectors have shape ``(n, 3)``.  The
rotation matrix ``R(q)`` maps material (body) components to spatial ones, so the
columns of ``R`` are the directors ``d1, d2, d3`` (``d1`` is the rod tangent).

Two layers, one formula each:

* kernels (numba, scalar, writing into caller-provided arrays, for the element
  loop): :func:`quat_left_into`, :func:`quat_right_into`,
  :func:`rotation_matrix_into` (of a not necessarily unit quaternion),
  :func:`increment_map`, :func:`quadratic_form`, :func:`relative_quaternion`;
* vectorised numpy functions over (..., 4) arrays built on those kernels
  (:func:`quat_left`, :func:`quat_right`, :func:`quat_multiply`,
  :func:`rotation_matrix`) plus exponential, logarithm and frame builders.

scipy's :class:`~scipy.spatial.transform.Rotation` converts from matrices
(:func:`director_frame`).  Quaternion signs are never canonicalised: a rod
rotated by 2π ends with ``-q``, which is the same rotation, and nothing here
breaks there.
"""
import numpy as np
from numba import njit
from scipy.spatial.transform import Rotation

@njit(cache=True)
def quat_left_into(q, L):
    """L(q) with L(q) @ p == q ⊗ p, written into L (4, 4)."""
    L[0, 0] = q[0]
    L[0, 1], L[0, 2], L[0, 3] = -q[1], -q[2], -q[3]
    L[1, 0], L[2, 0], L[3, 0] = q[1], q[2], q[3]
    L[1, 1], L[1, 2], L[1, 3] = q[0], -q[3], q[2]
    L[2, 1], L[2, 2], L[2, 3] = q[3], q[0], -q[1]
    L[3, 1], L[3, 2], L[3, 3] = -q[2], q[1], q[0]


@njit(cache=True)
def quat_right_into(q, R):
    """R(q) with R(q) @ p == p ⊗ q, written into R (4, 4)."""
    R[0, 0] = q[0]
    R[0, 1], R[0, 2], R[0, 3] = -q[1], -q[2], -q[3]
    R[1, 0], R[2, 0], R[3, 0] = q[1], q[2], q[3]
    R[1, 1], R[1, 2], R[1, 3] = q[0], q[3], -q[2]
    R[2, 1], R[2, 2], R[2, 3] = -q[3], q[0], q[1]
    R[3, 1], R[3, 2], R[3, 3] = q[2], -q[1], q[0]


@njit(cache=True)
def increment_map(q, T):
    """T (4, 3) = dq/dtheta = 1/2 R(q)[:, 1:] for the update q <- exp(theta) ⊗ q."""
    T[0, 0], T[0, 1], T[0, 2] = -0.5 * q[1], -0.5 * q[2], -0.5 * q[3]
    T[1, 0], T[1, 1], T[1, 2] = 0.5 * q[0], 0.5 * q[3], -0.5 * q[2]
    T[2, 0], T[2, 1], T[2, 2] = -0.5 * q[3], 0.5 * q[0], 0.5 * q[1]
    T[3, 0], T[3, 1], T[3, 2] = 0.5 * q[2], -0.5 * q[1], 0.5 * q[0]


@njit(cache=True)
def rotation_matrix_into(m, R):
    """Rotation matrix of the (not necessarily unit) quaternion m, into R (3, 3)."""
    w, x, y, z = m[0], m[1], m[2], m[3]
    s = 1.0 / (w * w + x * x + y * y + z * z)
    R[0, 0] = (w * w + x * x - y * y - z * z) * s
    R[1, 1] = (w * w - x * x + y * y - z * z) * s
    R[2, 2] = (w * w - x * x - y * y + z * z) * s
    R[0, 1] = 2.0 * (x * y - w * z) * s
    R[1, 0] = 2.0 * (x * y + w * z) * s
    R[0, 2] = 2.0 * (x * z + w * y) * s
    R[2, 0] = 2.0 * (x * z - w * y) * s
    R[1, 2] = 2.0 * (y * z - w * x) * s
    R[2, 1] = 2.0 * (y * z + w * x) * s


@njit(cache=True)
def quadratic_form(a, b, Q):
    """Q (4, 4) with a·rot(m) b == m·Q m, rot(m) = |m|^2 R(m/|m|) (Horn's matrix)."""
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    Q[0, 0] = ab
    Q[0, 1] = Q[1, 0] = b[1] * a[2] - b[2] * a[1]
    Q[0, 2] = Q[2, 0] = b[2] * a[0] - b[0] * a[2]
    Q[0, 3] = Q[3, 0] = b[0] * a[1] - b[1] * a[0]
    for i in range(3):
        for j in range(3):
            Q[i + 1, j + 1] = a[i] * b[j] + b[i] * a[j]
        Q[i + 1, i + 1] -= ab


@njit(cache=True)
def relative_quaternion(qA, qB, p):
    """p = conj(qA) ⊗ qB; returns the sign (+-1) that makes p0 >= 0."""
    p[0] = qA[0] * qB[0] + qA[1] * qB[1] + qA[2] * qB[2] + qA[3] * qB[3]
    p[1] = qA[0] * qB[1] - qB[0] * qA[1] - (qA[2] * qB[3] - qA[3] * qB[2])
    p[2] = qA[0] * qB[2] - qB[0] * qA[2] - (qA[3] * qB[1] - qA[1] * qB[3])
    p[3] = qA[0] * qB[3] - qB[0] * qA[3] - (qA[1] * qB[2] - qA[2] * qB[1])
    sign = 1.0
    if p[0] < 0.0:
        sign = -1.0
        for i in range(4):
            p[i] = -p[i]
    return sign


def hat(v):
    """Skew matrix ``hat(v) @ a == cross(v, a)``; ``v`` (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def quat_conjugate(q):
    """Inverse of a unit quaternion, (..., 4)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


@njit(cache=True)
def _each(which, q, out):
    """The kernel ``which`` (0 left, 1 right, 2 rotation matrix) on every row."""
    for i in range(q.shape[0]):
        if which == 0:
            quat_left_into(q[i], out[i])
        elif which == 1:
            quat_right_into(q[i], out[i])
        else:
            rotation_matrix_into(q[i], out[i])


def _batched(which, q, shape):
    q = np.asarray(q, dtype=float)
    flat = np.ascontiguousarray(q.reshape(-1, 4))
    out = np.empty((flat.shape[0],) + shape)
    _each(which, flat, out)
    return out.reshape(q.shape[:-1] + shape)


def quat_left(q):
    """Matrix of left multiplication, ``quat_left(p) @ q == p ⊗ q``; (..., 4, 4)."""
    return _batched(0, q, (4, 4))


def quat_right(q):
    """Matrix of right multiplication, ``quat_right(q) @ p == p ⊗ q``; (..., 4, 4)."""
    return _batched(1, q, (4, 4))


def quat_multiply(p, q):
    """Hamilton product ``p ⊗ q`` (rotation ``R(p) R(q)``), (n, 4)."""
    return np.einsum("...ij,...j->...i", quat_left(p), q)


def as_rotation(q):
    """scipy ``Rotation`` of scalar-first quaternions (n, 4)."""
    return Rotation.from_quat(q, scalar_first=True)


def quat_from_rotation(r):
    """Scalar-first quaternions (n, 4) of a scipy ``Rotation``, sign kept."""
    return np.atleast_2d(r.as_quat(scalar_first=True))


def rotation_matrix(q):
    """Rotation matrices (n, 3, 3) of unit quaternions (n, 4)."""
    return _batched(2, np.atleast_2d(q), (3, 3))


def quat_exp(theta):
    """Unit quaternions (..., 4) of the rotation vectors ``theta`` (..., 3).

    Written out rather than through scipy's Rotation: this is on the Newton
    hot path, where Rotation's per-call overhead (~100 us for tens of nodes)
    was most of the update's cost.
    """
    theta = np.asarray(theta, dtype=float)
    angle = np.linalg.norm(theta, axis=-1, keepdims=True)
    half = 0.5 * angle
    small = angle < 1e-6
    # sin(a/2)/a, with its Taylor series where a/2 is tiny
    ratio = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([np.cos(half), ratio * theta], axis=-1)


def rotate_spatially(q, theta):
    """Multiplicative update ``R <- exp(hat(theta)) R`` with spatial rotation
    vectors ``theta`` (n, 3); returns the new quaternions (n, 4), renormalised
    so round-off cannot drift off the unit sphere over many Newton steps."""
    qn = quat_multiply(quat_exp(theta), q)
    return qn / np.linalg.norm(qn, axis=-1, keepdims=True)


def spatial_turn(q, q0):
    """Spatial rotation vectors (n, 3) taking the frames q0 to q (n, 4): the
    inverse of :func:`rotate_spatially`, q = exp(hat(theta)) q0."""
    return rotation_vector(quat_multiply(q, quat_conjugate(q0)))


def rotation_vector(q):
    """Rotation vectors (n, 3), |theta| <= pi, of unit quaternions (n, 4) (the
    inverse of :func:`quat_exp`, written out for the same reason)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    q = np.where(q[:, :1] < 0.0, -q, q)                  # the shorter way round
    w, v = q[:, :1], q[:, 1:]
    s = np.linalg.norm(v, axis=1, keepdims=True)
    small = s < 1e-8
    # 2 atan2(s, w) / s, with its limit 2/w (1 - s^2/(3 w^2)) where s is tiny
    # (np.where evaluates both: w is ~1 where s is tiny, but may be 0 at a half turn)
    ws = np.where(small, w, 1.0)
    factor = np.where(small, 2.0 / ws * (1.0 - s**2 / (3.0 * ws**2)),
                      2.0 * np.arctan2(s, w) / np.where(small, 1.0, s))
    return factor * v


def rotation_from_vector(theta):
    """Quaternions (n, 4) of the rotations ``exp(hat(theta))``, theta (n, 3)."""
    return quat_exp(np.atleast_2d(theta))


def minimal_rotation(a, b):
    """Quaternions (n, 4) of the smallest rotations taking unit vectors a to b.

    Parallel transport of a frame along a polygon is a chain of these.
    Antiparallel pairs turn about an axis perpendicular to ``a``.
    """
    a = np.atleast_2d(a)
    b = np.atleast_2d(b)
    q = np.empty((a.shape[0], 4))
    q[:, 0] = 1.0 + np.einsum("ij,ij->i", a, b)
    q[:, 1:] = np.cross(a, b)
    bad = q[:, 0] < 1e-12
    if np.any(bad):
        helper = np.where(np.abs(a[bad, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
        axis = np.cross(a[bad], helper)
        q[bad, 0] = 0.0
        q[bad, 1:] = axis
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def director_frame(tangent, d3_hint):
    """Quaternions (n, 4) of frames with ``d1 = tangent`` and ``d3`` the part of
    ``d3_hint`` perpendicular to it, ``d2 = d3 x d1`` (inputs (n, 3), any length)."""
    t = np.atleast_2d(np.asarray(tangent, dtype=float))
    hint = np.broadcast_to(np.asarray(d3_hint, dtype=float), t.shape)
    t = t / np.linalg.norm(t, axis=1, keepdims=True)
    d3 = hint - np.einsum("ij,ij->i", hint, t)[:, None] * t
    norm = np.linalg.norm(d3, axis=1)
    if np.any(norm < 1e-9 * np.linalg.norm(hint, axis=1)) or np.any(norm == 0):
        raise ValueError("d3_hint must not be parallel to the tangent "
                         "(valid: any vector with a component across d1)")
    d3 = d3 / norm[:, None]
    frames = np.stack([t, np.cross(d3, t), d3], axis=2)
    return quat_from_rotation(Rotation.from_matrix(frames))


def transported_frames(tangents, first):
    """Twist-free frames along a sequence of unit tangents (n, 3): the first
    frame is the quaternion ``first`` (4,), each next one is the previous
    turned by the minimal rotation between consecutive tangents."""
    steps = minimal_rotation(tangents[:-1], tangents[1:])
    q = np.empty((tangents.shape[0], 4))
    q[0] = first
    for i in range(1, q.shape[0]):
        q[i] = quat_multiply(steps[i - 1], q[i - 1])
    return q / np.linalg.norm(q, axis=1, keepdims=True)
