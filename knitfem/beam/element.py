"""Two-node geometrically exact (Simo–Reissner) beam element with constant strains.

Kinematics of an element with nodes A, B, frames R_A, R_B, reference length h:

    psi   = log(R_A^T R_B)                   relative rotation of the two frames
    R_m   = R_A exp(psi / 2)                 geodesic mean (Crisfield–Jelenić triad)
    K     = psi / h                          torsion + curvature   (material)
    Gamma = W(psi)^-1 R_m^T (x_B - x_A) / h  axial + shear strain  (material)
    W     = h/2 (Gamma-Gamma0)·C_N (Gamma-Gamma0) + h/2 (K-K0)·C_M (K-K0)

The frames follow the geodesic R(s) = R_A exp(s psi / h), and positions follow
x' = R(s) Gamma with Gamma constant: the helicoidal (SE(3)) interpolation of
Sonneville, Cardona & Brüls (2014).  Integrating x' over the element gives
x_B - x_A = h R_m W(psi) Gamma with W = n n^T + sinc(theta/2) (I - n n^T),
theta = |psi|, n = psi/theta.  Consequences, each checked by a test:

* every state of constant strain (arc, helix, straight) is represented
  exactly, so an end moment rolls a cantilever into an exact circle;
* strains are constant on the element, so no quadrature is involved and
  there is no shear locking (the midpoint is the element's one point);
* Gamma and K depend on R_A^T R_B and R_A^T (x_B - x_A) only: objective and
  path independent; the buckling error is +(pi h / L_eff)^2 / 12.

In quaternions: with q_B's sign aligned to q_A, p = conj(q_A) ⊗ q_B = (w, v)
gives psi = g(w, |v|^2) v and W^-1 = c I + b v v^T (see
:mod:`knitfem.beam.series`); R_m is the rotation of m = q_A + q_B.  The energy
is differentiated as a function of y = (d = x_B - x_A, m, p) and chained to
the spatial increments R <- exp(hat(theta)) R; the consistent tangent is the
Hessian of the pulled-back energy minus hat(residual)/2 on the rotational
diagonal blocks: symmetric at equilibrium, not symmetrised here.

The per-element arithmetic is compiled with numba (a measured hot loop: the
vectorised numpy version of an earlier kernel took 76 ms at 1e4 elements).
Element dof order: (u_A, theta_A, u_B, theta_B).  Units: any consistent set;
C_N = (EA, GA2, GA3), C_M = (GJ, EI2, EI3).
"""
import numpy as np
from numba import njit, prange

from .element_blocks import hessian_y, kinematics, residual, stresses, tangent_matrix, workspace


@njit(cache=True, _nrt=False)
def _elements(lo, hi, XA, XB, QA, QB, H, G0, K0, CNs, CMs, energies, R, Ks, tangent, ws):
    """Elements lo..hi-1: energies, residuals R (n, 12) and, if tangent, Ks
    (n, 12, 12), block by block (:mod:`knitfem.beam.element_blocks`): strains,
    stresses and the gradient, residual, Hessian in (d, m, p), its chain rule.
    No reference counting here (``_nrt=False``: nothing is allocated; the
    workspace is unpacked once per chunk), which keeps the blocks' calls
    free."""
    qB, qAc, p, m, d, Gm, gamma = ws.qB, ws.qAc, ws.p, ws.m, ws.d, ws.Gm, ws.gamma
    N, Nt, nsp, S, dK, gp, kappa = ws.N, ws.Nt, ws.nsp, ws.S, ws.dK, ws.gp, ws.kappa
    gA, gB, gm, rA, rB, e, t4 = ws.gA, ws.gB, ws.gm, ws.rA, ws.rB, ws.e, ws.t4
    Jpsi, Rm, M, JpA, JpB, TA, TB = ws.Jpsi, ws.Rm, ws.M, ws.JpA, ws.JpB, ws.TA, ws.TB
    Hp, Hmm, Hmp, Hdm, Hdp, Hdd = ws.Hp, ws.Hmm, ws.Hmp, ws.Hdm, ws.Hdp, ws.Hdd
    JGm, MJG, GP, DN, CG, Q, QdN = ws.JGm, ws.MJG, ws.GP, ws.DN, ws.CG, ws.Q, ws.QdN
    HAA, HBB, HAB, T44, T43 = ws.HAA, ws.HBB, ws.HAB, ws.T44, ws.T43
    HdA, HdB, KAA, KBB, KAB = ws.HdA, ws.HdB, ws.KAA, ws.KBB, ws.KAB
    for el in range(lo, hi):
        qA, h, res = QA[el], H[el], R[el]
        lg, c_, b_, nm = kinematics(XA[el], XB[el], qA, QB[el], h, qB, p, m, d, Rm, Gm, M,
                                     gamma, kappa)
        for i in range(4):
            qAc[i] = -qA[i] if i > 0 else qA[i]
        v = p[1:]
        energies[el], f, alpha, beta, gam = stresses(
            h, v, lg, c_, b_, nm, m, d, Rm, Gm, M, gamma, G0[el], kappa, K0[el], CNs[el],
            CMs[el], N, S, dK, Nt, nsp, Jpsi, gp, gm, QdN, t4)
        residual(qA, qB, qAc, gp, gm, nsp, JpA, JpB, gA, gB, TA, TB, rA, rB, res)
        if not tangent:
            continue
        hessian_y(h, v, lg, c_, b_, nm, m, d, Gm, M, Rm, N, S, Nt, nsp, gm, f, alpha, beta,
                   gam, CNs[el], CMs[el], Jpsi, QdN, t4, e, Q, Hp, Hmm, Hmp, Hdm, Hdp, Hdd, JGm,
                   MJG, GP, DN, CG)
        tangent_matrix(qA, qB, gA, gB, gp, res, Hp, Hmm, Hmp, Hdm, Hdp, Hdd, JpA, JpB, TA, TB,
                       T44, T43, HAA, HBB, HAB, HdA, HdB, KAA, KBB, KAB, Ks[el])


@njit(cache=True, parallel=True)
def _all_elements(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent, chunks):
    n = xA.shape[0]
    energy = np.empty(n)
    res = np.empty((n, 12))
    K = np.empty((n if tangent else 1, 12, 12))
    nchunk = min(n, chunks)
    for c in prange(nchunk):
        _elements(c * n // nchunk, (c + 1) * n // nchunk, xA, xB, qA, qB, h, gamma0, kappa0,
                  CN, CM, energy, res, K, tangent, workspace())
    return energy, res, K


@njit(cache=True)
def _all_elements_serial(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent):
    """The same loop without threads (a separate function: numba's cache keys
    on the function, so one body cannot be cached both ways)."""
    n = xA.shape[0]
    energy = np.empty(n)
    res = np.empty((n, 12))
    K = np.empty((n if tangent else 1, 12, 12))
    _elements(0, n, xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, energy, res, K, tangent,
              workspace())
    return energy, res, K


# the triad's geodesic mean (and the chord map W^-1) is singular where the two
# end frames differ by exactly a half turn (the kernel divides by zero there).
# Frames 179.9 deg apart are legitimate -- a frame flipped at an inflection
# and the natural twist taking it back (S-rod and stress cases) -- and the
# kernel's tangent is verified there; what is refused is the singular point
# itself, reached when near-zero GJ lets the frames spin (a 4 x 4 swatch at
# GJ/EI = 1e-3 landed on cos(angle/2) = 0.0 exactly)
MAX_ELEMENT_TURN = np.pi - 2e-9


class ElementTurnError(ValueError):
    """An element's end frames differ by more than :data:`MAX_ELEMENT_TURN`;
    ``element`` is its index, ``angle`` the turn (rad)."""

    def __init__(self, element, angle):
        super().__init__(f"element {element}: its end frames differ by half a turn "
                         f"({np.degrees(angle):.7f} deg), where its kinematics is singular (a "
                         "yarn twisted by half a turn over one element: torsional stiffness "
                         "too small, or too few elements)")
        self.element, self.angle = int(element), float(angle)


def element_turns(qA, qB):
    """Angle (rad) between the end frames of every element, in [0, pi]."""
    c = np.minimum(np.abs(np.einsum("ij,ij->i", qA, qB)), 1.0)
    return 2.0 * np.arccos(c)


# Threads pay off from a few thousand elements; below, their start-up (~0.3 ms)
# costs more than the loop (60 elements: 0.15 ms serial).
PARALLEL_FROM = 2000


def element_forces(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent=True):
    """Energy, residual and consistent tangent of every element.

    Parameters
    ----------
    xA, xB : (n, 3) nodal positions.
    qA, qB : (n, 4) nodal unit quaternions (scalar first).
    h : (n,) reference element lengths.
    gamma0, kappa0 : (n, 3) stress-free strains (the rod's natural shape).
    CN, CM : (n, 3) diagonal stiffnesses (EA, GA2, GA3), (GJ, EI2, EI3).

    Returns
    -------
    energy : (n,)
    residual : (n, 12) internal generalised forces, work-conjugate to
        (u_A, theta_A, u_B, theta_B) with spatial rotation increments.
    K : (n, 12, 12) derivative of ``residual`` along the multiplicative update,
        or None when ``tangent`` is False.

    Raises :class:`ElementTurnError` for an element whose end frames differ
    by more than :data:`MAX_ELEMENT_TURN` (there the kinematics is singular).
    """
    args = [np.ascontiguousarray(a, dtype=np.float64)
            for a in (xA, xB, qA, qB, h, gamma0, kappa0, CN, CM)]
    if len(h):
        turns = element_turns(args[2], args[3])
        worst = int(np.argmax(turns))
        if not turns[worst] <= MAX_ELEMENT_TURN:
            raise ElementTurnError(worst, turns[worst])
    if args[0].shape[0] >= PARALLEL_FROM:
        energy, res, K = _all_elements(*args, bool(tangent), 64)
    else:
        energy, res, K = _all_elements_serial(*args, bool(tangent))
    return energy, res, (K if tangent else None)


@njit(cache=True)
def _strains(xA, xB, qA, qB, h, gamma, kappa, Rm):
    """Material strains Gamma, K and the midpoint triad R_m of one element."""
    kinematics(xA, xB, qA, qB, h, np.empty(4), np.empty(4), np.empty(4), np.empty(3), Rm,
                np.empty(3), np.empty((3, 3)), gamma, kappa)


@njit(cache=True)
def _all_strains(xA, xB, qA, qB, h):
    n = xA.shape[0]
    gamma = np.empty((n, 3))
    kappa = np.empty((n, 3))
    frames = np.empty((n, 3, 3))
    for e in range(n):
        _strains(xA[e], xB[e], qA[e], qB[e], h[e], gamma[e], kappa[e], frames[e])
    return gamma, kappa, frames


def element_strains(xA, xB, qA, qB, h):
    """Material strains Gamma (n, 3), K (n, 3) and midpoint triads (n, 3, 3)."""
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (xA, xB, qA, qB, h)]
    return _all_strains(*args)
