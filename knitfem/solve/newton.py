"""Newton's method with a backtracking line search, on any problem.

A *problem* is an object with two methods:

``evaluate(x, jacobian) -> (r, J, ref)``
    residual vector r (n,), its Jacobian J (sparse or dense, None when
    ``jacobian`` is False) and a reference magnitude ``ref`` > 0 for the
    relative residual |r| / ref (e.g. the size of the forces in play).
``retract(x, dx) -> x``
    the state reached by the increment dx (n,); for plain vectors x + dx,
    for rotations a multiplicative update.

and optionally ``start(x) -> x`` (make x satisfy the problem's constraints
before the first iteration), ``norm(r) -> float`` (a weighted norm when the
entries of r carry different units; default Euclidean) and ``noise(x) ->
float`` (the round-off level of |r| at x: stiff problems cannot reduce the
residual below it, so the tolerance never asks for less).  Nothing here knows
about beams.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg


STAGNATION = 10.0      # a line search that stalls within this factor of the noise has converged


class NewtonError(RuntimeError):
    """Newton failed.  ``reason`` is one of 'max_iterations', 'nonfinite',
    'singular', 'line_search'; ``state`` is the last iterate, ``history`` the
    relative residuals so far."""

    def __init__(self, reason, message, state, history):
        super().__init__(message)
        self.reason = reason
        self.state = state
        self.history = list(history)


@dataclass
class NewtonResult:
    state: object
    iterations: int
    history: list = field(default_factory=list)   # relative residual per iterate
    roundoff_limited: bool = False                # stopped at the noise floor above rtol

    @property
    def residual(self):
        return self.history[-1]


def linear_solve(J, b):
    """Solve J x = b for a sparse or dense J, or any object with ``solve(b)``
    (e.g. a bordered system); a singular J raises RuntimeError or LinAlgError."""
    if hasattr(J, "solve"):
        return J.solve(b)
    if sparse.issparse(J):
        with np.errstate(all="ignore"):
            lu = splinalg.splu(J.tocsc())       # RuntimeError when exactly singular
        return lu.solve(b)
    return np.linalg.solve(J, b)


def newton(problem, x0, *, rtol=1e-10, atol=0.0, max_iter=25, line_search=False,
           max_cuts=10, where=""):
    """Solve ``problem`` from ``x0`` to |r| <= rtol * ref + atol.

    Returns a :class:`NewtonResult`; raises :class:`NewtonError` with the last
    state when the iteration diverges, stalls, meets a singular Jacobian or a
    non-finite residual.  ``where`` is added to messages (e.g. 'load 0.3').
    """
    at = f" at {where}" if where else ""
    norm_of = getattr(problem, "norm", np.linalg.norm)
    noise_of = getattr(problem, "noise", lambda _: 0.0)
    x = problem.start(x0) if hasattr(problem, "start") else x0
    r, J, ref = problem.evaluate(x, True)
    history = []
    for it in range(max_iter + 1):
        norm = float(norm_of(r))
        if not np.isfinite(norm):
            raise NewtonError("nonfinite", f"Newton{at}: residual is not finite at iteration "
                              f"{it} (diverged or invalid state)", x, history)
        history.append(norm / ref)
        # below the round-off level nothing is measurable: a stress-free start, or
        # loads too small for the stiffness, converge there (and say so)
        noise = noise_of(x)
        if norm <= max(rtol * ref, noise) + atol:
            return NewtonResult(x, it, history, roundoff_limited=rtol * ref < noise)
        if it == max_iter:
            break
        try:
            dx = -linear_solve(J, r)
        except (RuntimeError, np.linalg.LinAlgError) as err:
            raise NewtonError("singular", f"Newton{at}: Jacobian is singular at iteration {it} "
                              f"(under-constrained model or a critical point): {err}",
                              x, history) from None
        if not np.all(np.isfinite(dx)):
            raise NewtonError("singular", f"Newton{at}: the Newton step is not finite at "
                              f"iteration {it} (Jacobian numerically singular)", x, history)
        alpha = 1.0
        x_try = problem.retract(x, dx)
        r_try, J_try, ref_try = problem.evaluate(x_try, True)
        if line_search:
            cuts = 0
            while not (norm_of(r_try) <= (1.0 - 1e-4 * alpha) * norm):
                cuts += 1
                if cuts > max_cuts and norm <= STAGNATION * noise:
                    # no descent left at the round-off floor: that is convergence
                    return NewtonResult(x, it, history, roundoff_limited=True)
                if cuts > max_cuts:
                    raise NewtonError("line_search", f"Newton{at}: line search found no "
                                      f"decrease of |r| = {norm:.3e} along the Newton step at "
                                      f"iteration {it}", x, history)
                alpha *= 0.5
                x_try = problem.retract(x, alpha * dx)
                r_try, J_try, ref_try = problem.evaluate(x_try, False)
            if J_try is None:
                r_try, J_try, ref_try = problem.evaluate(x_try, True)
        x, r, J, ref = x_try, r_try, J_try, ref_try
    raise NewtonError("max_iterations", f"Newton{at}: no convergence in {max_iter} iterations, "
                      f"relative residual {history[-1]:.3e} > {rtol:.1e}", x, history)
