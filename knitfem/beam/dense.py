"""Small dense algebra for the element kernel (3 x 4 and 4 x 4 blocks), numba.

All functions write into caller-provided arrays: allocating inside the element
loop costs more than the arithmetic.
"""
from numba import njit


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
