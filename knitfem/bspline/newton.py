"""Newton's method on the B-spline energy: the finish of a relaxation.

Explicit relaxation stalls on the soft modes of a knit (sliding, the swatch
rolling up); Newton with the exact Hessian converges there in a handful of
steps.  Globalised for states far from equilibrium, where the Hessian is
indefinite: Levenberg-Marquardt shift H + mu D (D the Hessian's diagonal),
mu raised until the direction descends, then steered by how well the
quadratic model predicted the energy drop (a trust region in disguise);
every step capped so no control point moves more than ``max_move`` (a fraction of the yarn radius:
no yarn can pass through another between two energy checks).  A free body's
six rigid motions make H singular; the shift (never below ``mu_min``) keeps
the system solvable and the gradient has no rigid component anyway.
Sparse LU (SuperLU, COLAMD order) per step; no dense matrix.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

from .relax import Relaxed, RelaxationError, converged, largest_move, progress_bar


@dataclass
class NewtonReport:
    factorisations: int = 0
    shifts: list = field(default_factory=list)


def relax_newton(model, y0, *, rtol=1e-8, atol=0.0, max_iter=100, max_move=None, mu0=1e-3,
                 mu_min=1e-10, progress=False, callback=None):
    """Minimise the energy from y0 by globalised Newton; :class:`Relaxed`
    (method "newton") or :class:`RelaxationError` with the last state.

    atol: absolute force norm that also counts as converged (for states with
    no forces left, where a relative residual means nothing); max_move:
    largest control-point move per step (default r/4 of the contact law,
    unlimited without contact); callback(y, residual) per step.  mu follows
    the ratio rho of the energy drop to the drop the quadratic model
    predicts (Levenberg-Marquardt): rho > 3/4 lowers it, rho < 1/4 raises it,
    a step that does not lower the energy is refused."""
    y = np.asarray(y0, float).copy()
    if max_move is None:
        contact = getattr(model, "contact", None)
        max_move = 0.25 * contact.radius if contact is not None else np.inf
    Z, _ = model.reduction()
    E, g, ref = model.reduced_energy(y)
    history = [float(np.linalg.norm(g) / ref)]
    mu = mu0
    report = NewtonReport()
    bar = progress_bar(progress, max_iter, "Newton")
    try:
        for it in range(1, max_iter + 1):
            if converged(g, ref, rtol, model, atol):
                return _done(model, y, it - 1, history, E, report)
            H = model.reduced_hessian(y)
            D = np.maximum(np.abs(H.diagonal()), 1e-300)
            step, mu = _descent(H, D, g, mu, mu_min, report)
            step *= min(1.0, max_move / max(largest_move(Z, step), 1e-300))
            predicted = -(g @ step + 0.5 * step @ (H @ step))
            E_new, g_new, ref_new = model.reduced_energy(y + step)
            rho = (E - E_new) / predicted if predicted > 0 else -1.0
            if predicted <= 1e-14 * abs(E):          # round-off level: judge by the force
                rho = 1.0 if np.linalg.norm(g_new) < np.linalg.norm(g) else -1.0
            if np.isfinite(E_new) and rho > 1e-4:
                y, E, g, ref = y + step, E_new, g_new, ref_new
                mu = max(mu_min, mu / 4.0) if rho > 0.75 else (mu * 4.0 if rho < 0.25 else mu)
            else:
                mu *= 4.0
            history.append(float(np.linalg.norm(g) / ref))
            if bar is not None:
                bar.update()
                bar.set_postfix(residual=f"{history[-1]:.1e}", mu=f"{mu:.0e}")
            if callback is not None:
                callback(y, history[-1])
        if converged(g, ref, rtol, model, atol):
            return _done(model, y, max_iter, history, E, report)
    finally:
        if bar is not None:
            bar.close()
    raise RelaxationError(f"Newton did not reach relative residual {rtol:.1e} in {max_iter} "
                          f"steps (last {history[-1]:.2e})", y, history)


def _done(model, y, iterations, history, E, report):
    return Relaxed(y, iterations, history[-1], E, "newton", history, report=report)


def _descent(H, D, g, mu, mu_min, report):
    """Solve (H + mu D) p = -g, raising mu until p descends; returns (p, mu)."""
    n = H.shape[0]
    Dm = sparse.diags(D)
    for _ in range(40):
        A = (H + mu * Dm).tocsc()
        report.factorisations += 1
        try:
            p = splinalg.splu(A, permc_spec="COLAMD").solve(-g)
        except RuntimeError:               # exactly singular: shift more
            p = None
        if p is not None and np.all(np.isfinite(p)):
            # descent with some margin: the shifted matrix is close to positive definite
            if g @ p < -1e-12 * np.linalg.norm(g) * np.linalg.norm(p):
                report.shifts.append(mu)
                return p, mu
        mu = max(mu * 10.0, mu_min)
    raise RelaxationError(f"no descent direction at {n} unknowns even with shift {mu:.1e}",
                          None, [])
