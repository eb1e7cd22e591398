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
entries of r carry different units; default Euclidean), ``noise(x) ->
float`` (the round-off level of |r|: stiff problems cannot reduce the
residual below it, so the tolerance never asks for less) and
``correction_norm(dx) -> float`` (the size of an increment relative to the
problem's own length scales, dimensionless).  Nothing here knows about beams.

When is a state converged?  Three rules keep the test from being fooled:

* ``ref`` and ``noise`` must be *fixed scales of the problem* (its loads,
  stiffness and geometry), not of the current iterate: a round-off floor that
  grows with |x| accepts a state thrown far away by a bad predictor.
* A start is accepted without iterating only if it meets ``rtol * ref`` itself;
  the round-off floor counts only after a Newton correction has been computed.
* After iterating, the residual must be within tolerance (or the floor) *and*
  the last correction small (``correction_norm <= ctol``), so a residual that
  is small only because the floor is large does not pass.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg


STAGNATION = 10.0      # a line search that stalls within this factor of the noise has converged


class NewtonError(RuntimeError):
    """Newton failed.  ``reason`` is one of 'max_iterations', 'nonfinite',
    'singular', 'line_search', 'unstable'; ``state`` is the last iterate,
    ``history`` the relative residuals so far."""

    def __init__(self, reason, message, state, history):
        super().__init__(message)
        self.reason = reason
        self.state = state
        self.history = list(history)

    def __reduce__(self):
        # picklable (process pools hand errors back to the parent)
        return (type(self), (self.reason, str(self), self.state, self.history))


@dataclass
class NewtonResult:
    state: object
    iterations: int
    history: list = field(default_factory=list)   # relative residual per iterate
    roundoff_limited: bool = False                # stopped at the noise floor above rtol
    correction: float = 0.0                       # size of the last correction (correction_norm)

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


def newton(problem, x0, *, rtol=1e-10, atol=0.0, ctol=1e-6, max_iter=25, line_search=False,
           max_cuts=10, where=""):
    """Solve ``problem`` from ``x0`` to |r| <= rtol * ref + atol (or the round-off
    floor) with a last correction of size <= ctol (see the module docstring).

    Returns a :class:`NewtonResult`; raises :class:`NewtonError` with the last
    state when the iteration diverges, stalls, meets a singular Jacobian or a
    non-finite residual.  ``where`` is added to messages (e.g. 'load 0.3').
    """
    at = f" at {where}" if where else ""
    norm_of = getattr(problem, "norm", np.linalg.norm)
    noise_of = getattr(problem, "noise", lambda _: 0.0)
    size_of = getattr(problem, "correction_norm", None)
    x = problem.start(x0) if hasattr(problem, "start") else x0
    r, J, ref = problem.evaluate(x, True)
    history = []
    correction = np.inf          # no correction computed yet
    for it in range(max_iter + 1):
        norm = float(norm_of(r))
        if not np.isfinite(norm):
            raise NewtonError("nonfinite", f"Newton{at}: residual is not finite at iteration "
                              f"{it} (diverged or invalid state)", x, history)
        history.append(norm / ref)
        noise = noise_of(x)
        if it == 0:
            converged = norm <= rtol * ref + atol
        else:
            # below the round-off level nothing is measurable: a stress-free start,
            # or loads too small for the stiffness, converge there (and say so)
            converged = norm <= max(rtol * ref, noise) + atol and \
                (size_of is None or correction <= ctol)
        if converged:
            return NewtonResult(x, it, history, roundoff_limited=rtol * ref + atol < norm,
                                correction=0.0 if it == 0 else correction)
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
                if cuts > max_cuts and norm <= STAGNATION * noise and \
                        size_of is not None and size_of(dx) <= ctol:
                    # no descent left at the round-off floor, and the full Newton
                    # correction from here is small: that is convergence
                    return NewtonResult(x, it, history, roundoff_limited=True,
                                        correction=size_of(dx))
                if cuts > max_cuts:
                    raise NewtonError("line_search", f"Newton{at}: line search found no "
                                      f"decrease of |r| = {norm:.3e} along the Newton step at "
                                      f"iteration {it}", x, history)
                alpha *= 0.5
                x_try = problem.retract(x, alpha * dx)
                r_try, J_try, ref_try = problem.evaluate(x_try, False)
            if J_try is None:
                r_try, J_try, ref_try = problem.evaluate(x_try, True)
        correction = size_of(alpha * dx) if size_of is not None else 0.0
        x, r, J, ref = x_try, r_try, J_try, ref_try
    raise NewtonError("max_iterations", f"Newton{at}: no convergence in {max_iter} iterations, "
                      f"relative residual {history[-1]:.3e} > {rtol:.1e}"
                      + (f" (last correction {correction:.1e} > {ctol:.0e})"
                         if size_of is not None and history[-1] * ref <= max(rtol * ref, noise)
                         else ""), x, history)
