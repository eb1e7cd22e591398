"""Smooth scalar functions of a relative rotation quaternion p = (w, v), t = |v|^2,
with the partial derivatives the beam kernel needs (numba-compiled).

* ``log_coefficients``: g(w, t) = 2 atan2(sqrt t, w) / sqrt t, so that
  psi = g v is the rotation vector of p (any length, w > 0).
* ``chord_coefficients``: c(w, t) = (theta/2) / sin(theta/2) and
  b(w, t) = (1 - c) / t, theta = |psi|; ``c I + b v v^T`` maps the chord of an
  element to its strain along the helicoidal (constant-strain) interpolation.

Both are written through eps = t / w^2 = tan^2(theta/2); below a threshold the
closed forms lose digits to cancellation and Taylor series in eps take over.
"""
import numpy as np
from numba import njit

_LOG_EPS = 0.02
_LOG_TERMS = 16
_CHORD_EPS = 0.25
_CHORD_TERMS = 40


def _chord_series(n):
    """Taylor coefficients of B(eps) = (C(eps) - 1) / eps with
    C = atan(sqrt eps) sqrt(1 + eps) / sqrt eps."""
    k = np.arange(n + 1)
    atan_over_x = (-1.0) ** k / (2 * k + 1)
    sqrt1p = np.ones(n + 1)
    for j in range(1, n + 1):
        sqrt1p[j] = sqrt1p[j - 1] * (0.5 - (j - 1)) / j
    C = np.convolve(atan_over_x, sqrt1p)[: n + 1]
    return C[1:].copy()


_B = _chord_series(_CHORD_TERMS)
_B1 = _B[1:] * np.arange(1, _CHORD_TERMS)
_B2 = _B1[1:] * np.arange(1, _CHORD_TERMS - 1)


@njit(cache=True)
def _poly(coef, x, terms):
    """Horner on the first ``terms`` coefficients."""
    acc = 0.0
    for i in range(min(terms, coef.shape[0]) - 1, -1, -1):
        acc = acc * x + coef[i]
    return acc


@njit(cache=True)
def _terms(eps):
    """Series terms for ~1e-18 truncation at eps (most elements turn by < 0.1 rad,
    eps < 1e-3, where 8 terms suffice and the kernel runs twice as fast)."""
    if eps < 1e-3:
        return 8
    if eps < 1e-2:
        return 12
    if eps < 0.05:
        return 20
    return 40


@njit(cache=True)
def log_coefficients(w, t):
    """g, g_w, g_t, g_ww, g_wt, g_tt of g(w, t) = 2 atan2(sqrt t, w) / sqrt t."""
    r2 = w * w + t
    g_w = -2.0 / r2
    g_ww = 4.0 * w / (r2 * r2)
    g_wt = 2.0 / (r2 * r2)
    eps = t / max(w * w, 1e-300)
    if eps < _LOG_EPS:
        # atan(x)/x = sum_k (-x^2)^k / (2k+1), differentiated term by term in t
        g = 0.0
        g_t = 0.0
        g_tt = 0.0
        pw = 1.0
        for k in range(min(_LOG_TERMS, _terms(eps))):
            sgn = 1.0 if k % 2 == 0 else -1.0
            g += sgn * pw / (2 * k + 1)
            g_t -= sgn * (k + 1) * pw / (2 * k + 3)
            g_tt += sgn * (k + 2) * (k + 1) * pw / (2 * k + 5)
            pw *= eps
        g *= 2.0 / w
        g_t *= 2.0 / w**3
        g_tt *= 2.0 / w**5
    else:
        s = np.sqrt(t)
        ang = np.arctan2(s, w)
        g = 2.0 * ang / s
        g_t = (w * s / r2 - ang) / (s * t)
        g_tt = -(w / (r2 * r2) + 1.5 * g_t) / t
    return g, g_w, g_t, g_ww, g_wt, g_tt


@njit(cache=True)
def _chord_B(eps):
    """B(eps) = (C - 1)/eps and its first two derivatives in eps."""
    if eps < _CHORD_EPS:
        m = _terms(eps)
        return _poly(_B, eps, m), _poly(_B1, eps, m), _poly(_B2, eps, m)
    x = np.sqrt(eps)
    u = np.arctan(x)
    r = np.sqrt(1.0 + eps)
    C = u * r / x
    C1 = (1.0 - u / x) / (2.0 * eps * r)
    C2 = (u * (4.0 * eps + 3.0) / (eps**2 * x) - 3.0 * (eps + 1.0) / eps**2) / (4.0 * r**3)
    B = (C - 1.0) / eps
    B1 = (C1 - B) / eps
    B2 = (C2 - 2.0 * B1) / eps
    return B, B1, B2


@njit(cache=True)
def chord_coefficients(w, t):
    """(c, c_w, c_t, c_ww, c_wt, c_tt), (b, b_w, b_t, b_ww, b_wt, b_tt) with
    c = (theta/2)/sin(theta/2) and b = (1 - c)/t as functions of (w, t)."""
    w2 = w * w
    eps = t / w2
    B, B1, B2 = _chord_B(eps)
    C1 = B + eps * B1            # C = 1 + eps B
    C2 = 2.0 * B1 + eps * B2
    c = 1.0 + eps * B
    c_t = C1 / w2
    c_w = -2.0 * eps * C1 / w
    c_tt = C2 / (w2 * w2)
    c_wt = -2.0 * (eps * C2 + C1) / (w2 * w)
    c_ww = (4.0 * eps * eps * C2 + 6.0 * eps * C1) / w2
    b = -B / w2
    b_t = -B1 / (w2 * w2)
    b_tt = -B2 / (w2 * w2 * w2)
    b_w = 2.0 * (eps * B1 + B) / (w2 * w)
    b_wt = 2.0 * (2.0 * B1 + eps * B2) / (w2 * w2 * w)
    b_ww = -2.0 * (2.0 * eps * (2.0 * B1 + eps * B2) + 3.0 * (eps * B1 + B)) / (w2 * w2)
    return (c, c_w, c_t, c_ww, c_wt, c_tt), (b, b_w, b_t, b_ww, b_wt, b_tt)
