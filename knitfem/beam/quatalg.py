"""Small dense and quaternion algebra for the element kernel, compiled with numba.

All functions write into caller-provided arrays: allocating inside the element
loop costs more than the arithmetic.  Quaternions are (w, x, y, z).
"""
from numba import njit


@njit(cache=True)
def quat_left(q, L):
    """L(q) with L(q) @ p == q ⊗ p, written into L (4, 4)."""
    L[0, 0] = q[0]
    L[0, 1], L[0, 2], L[0, 3] = -q[1], -q[2], -q[3]
    L[1, 0], L[2, 0], L[3, 0] = q[1], q[2], q[3]
    L[1, 1], L[1, 2], L[1, 3] = q[0], -q[3], q[2]
    L[2, 1], L[2, 2], L[2, 3] = q[3], q[0], -q[1]
    L[3, 1], L[3, 2], L[3, 3] = -q[2], q[1], q[0]


@njit(cache=True)
def quat_right(q, R):
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
def rotation_matrix(m, R):
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
def mm(A, B, C):
    """C = A @ B."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            C[i, j] = acc


@njit(cache=True)
def tmm(A, B, C):
    """C = A^T @ B."""
    for i in range(A.shape[1]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[0]):
                acc += A[k, i] * B[k, j]
            C[i, j] = acc


@njit(cache=True)
def congruence(T, H, U, tmp, C):
    """C = T^T @ H @ U (tmp holds H @ U)."""
    mm(H, U, tmp)
    tmm(T, tmp, C)


@njit(cache=True)
def mv(A, x, y):
    """y = A @ x."""
    for i in range(A.shape[0]):
        acc = 0.0
        for j in range(A.shape[1]):
            acc += A[i, j] * x[j]
        y[i] = acc


@njit(cache=True)
def tmv(A, x, y):
    """y = A^T @ x."""
    for i in range(A.shape[1]):
        acc = 0.0
        for j in range(A.shape[0]):
            acc += A[j, i] * x[j]
        y[i] = acc


@njit(cache=True)
def dot(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


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
