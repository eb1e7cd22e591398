"""Energy minimisation for relaxation far from equilibrium.

Plain Newton from a knitted shape fails at once: the tangent is indefinite
there and a Newton step throws yarns radii away.  This is a modified Newton
method on the energy (a Levenberg-Marquardt / trust-region hybrid):

    (H + mu D) dx = -g,     D = diag of the PSD model (Marquardt scaling),

where H is the exact (symmetric) Hessian whenever H + mu D is positive
definite for mu or one of up to three tenfold larger shifts (the shift
that was needed is kept for the next iteration), and otherwise a positive
semi-definite model of it (per-block projection, see
:mod:`knitfem.solve.psd`); the step is capped by the
problem's ``step_limit`` (no contact point moves far enough to tunnel
through a yarn), then a backtracking line search on the energy (Armijo)
accepts it.  mu shrinks after full steps and grows after cut or failed
ones.  Every accepted step lowers the energy, so the result is a local
minimum: a stable equilibrium (verified by the caller's final Newton solve).

Problem protocol (nothing here knows about beams):

``evaluate(x, hessian) -> (E, g, H, H_psd)``
    energy, gradient (n,), sparse symmetric Hessian and a PSD model of it
    (None, None when ``hessian`` is False).
``retract(x, dx) -> x``; ``residual(g) -> float``, the convergence measure
(a relative residual against a fixed scale); optional ``step_limit(x, dx) ->
float`` in (0, 1], the largest fraction of dx that may be taken; optional
``depth() -> float`` (with ``depth_limit``, default inf): how deep the last
evaluated state pushes its bodies into each other (a length; the last
evaluation is always the current state or the trial): a trial step deeper than
``max(depth_limit, depth now)`` is cut like one that raises the energy, so
no accepted state passes the limit unless the start already did (and then
goes no deeper).  A penalty contact lowers the energy by letting a tense
yarn cut through a crossing, so Armijo alone accepted transient
penetrations of 5.5 % d on the way (25 x 35 swatch).  A trial state outside
the model (``evaluate`` returning an infinite energy, with the reason in the
problem's optional ``refusal``) is cut too, and a stall names it.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse

from .factor import Cholesky, Factorizer, NotPositiveDefinite

MU_MIN, MU_MAX = 1e-10, 1e8
SHIFTS = 4                    # tries of the exact Hessian, mu x 10 each, before the PSD model


class RelaxationError(RuntimeError):
    """The minimisation stalled or ran out of iterations; ``state`` is the
    lowest-energy state reached, ``history`` the iterations so far."""

    def __init__(self, message, state, history):
        super().__init__(message)
        self.state = state
        self.history = list(history)

    def __reduce__(self):
        return (type(self), (str(self), self.state, self.history))


@dataclass
class Relaxed:
    state: object
    energy: float
    residual: float
    iterations: int
    converged: bool
    history: list = field(default_factory=list)   # (E, residual, mu, t, hessian used, step cap)
    stopped: bool = False   # ended unconverged by the caller's ``stop``


def _factor(H, D, mu, factorize=Cholesky):
    return factorize(sparse.csc_matrix(H + sparse.diags(mu * D)))


def minimize(problem, x0, *, tol=1e-6, max_iter=500, mu=1e-3, max_cuts=12, progress=None,
             raise_on_failure=True, stop=None, shifts=SHIFTS):
    """Minimise the problem's energy from ``x0`` until ``residual(g) <= tol``.

    Returns :class:`Relaxed`; raises :class:`RelaxationError` (keeping the
    state) when mu exceeds its bound (no descent left: a kink or a wrong
    gradient) or after ``max_iter`` iterations, unless ``raise_on_failure`` is
    False (then ``converged`` says so).  ``progress(iteration, E, residual)``
    is called after every iteration; ``stop(iteration, E, residual)``, before
    every step (the problem's last evaluation is then the current state;
    iteration 0 is the start), may end the minimisation unconverged
    (``stopped``): the caller wants to change the problem first.
    ``shifts``: tries of the exact Hessian (shifted mu, 10 mu, ...) before the
    PSD model.
    """
    x = x0
    E, g, H, Hp = problem.evaluate(x, True)
    history = []
    exact_failed, shift_last = 0, 0.0
    full_before = False             # the last step was a full one
    factorize = Factorizer()
    limit = getattr(problem, "step_limit", None)
    depth = getattr(problem, "depth", None)
    depth_limit = getattr(problem, "depth_limit", np.inf)
    deepest = depth() if depth is not None else 0.0
    for it in range(max_iter + 1):
        res = float(problem.residual(g))
        if not np.isfinite(E) or not np.isfinite(res):
            raise RelaxationError(f"relaxation: energy or residual not finite at iteration {it}",
                                  x, history)
        if res <= tol:
            return Relaxed(x, E, res, it, True, history)
        if it == max_iter:
            break
        if stop is not None and stop(it, E, res):
            return Relaxed(x, E, res, it, False, history, stopped=True)
        D = np.abs(H.diagonal())
        D = np.maximum(D, 1e-12 * max(D.max(), 1e-300))
        used = None
        # the exact Hessian first (fast local convergence); after it failed,
        # try it again only every few iterations
        if exact_failed == 0 or it % 5 == 0:
            # an indefinite Hessian shifted until positive definite keeps the
            # coupling that the per-block PSD model throws away: on a 5 x 5
            # swatch at alpha 0.2 the PSD steps crept (residual 0.15 -> 0.046
            # in 180 full steps) where the shifted ones converged in 198
            shift = max(mu, shift_last / 3.0)
            for _ in range(shifts):
                try:
                    chol, used = _factor(H, D, shift, factorize), "exact"
                    exact_failed, shift_last = 0, (shift if shift > mu else 0.0)
                    mu = shift
                    break
                except NotPositiveDefinite:
                    shift = max(10.0 * shift, 1e-6)
            if used is None:
                exact_failed += 1
        model = None
        while used is None:
            model = Hp() if model is None else model
            try:
                chol, used = _factor(model, D, mu, factorize), "psd"
            except NotPositiveDefinite:
                mu = min(10.0 * mu, MU_MAX)
                if mu >= MU_MAX:
                    raise RelaxationError("relaxation: no positive definite model of the "
                                          f"Hessian at iteration {it}", x, history) from None
        dx = -chol.solve(g)
        cap = min(1.0, float(limit(x, dx))) if limit is not None else 1.0
        dx = dx * cap
        slope = float(g @ dx)
        t, accepted = 1.0, False
        # near a minimum the energy's decrease falls below its round-off
        # (~1e-15 |E|, summed over many terms): there a step that does not
        # raise E beyond that noise is accepted if it lowers the residual
        noise = 1e-12 * max(abs(E), 1e-300)
        too_deep = 0            # trials of this line search that only the depth guard cut
        refused = 0             # trials outside the model (infinite energy)
        # after a full step the full trial is mostly taken: its Hessian comes
        # with it (E and g are the same bits either way, tested), saving the
        # evaluation of the accepted state that would follow
        with_hessian = full_before
        for cut in range(max_cuts):
            x_try = problem.retract(x, t * dx)
            trial = problem.evaluate(x_try, with_hessian and cut == 0)
            E_try, g_try = trial[:2]
            lower = np.isfinite(E_try) and (
                E_try <= E + 1e-4 * t * slope or
                (-t * slope < noise and E_try <= E + noise and problem.residual(g_try) < res))
            refused += not np.isfinite(E_try)
            if lower and depth is not None and depth() > max(depth_limit, deepest):
                too_deep += 1
            elif lower:
                accepted = True
                break
            t *= 0.5
        if accepted:
            x = x_try
            E, g, H, Hp = trial if trial[2] is not None else problem.evaluate(x, True)
            deepest = depth() if depth is not None else 0.0
            mu = max(mu / 3.0, MU_MIN) if t == 1.0 else (2.0 * mu if t < 0.25 else mu)
        else:
            # the problem's last evaluation is x again: hooks that read it
            # (progress, depth) see the current state, not a rejected trial
            problem.evaluate(x, False)
            mu = min(10.0 * mu, MU_MAX)
            if mu >= MU_MAX:
                why = (f"; {too_deep} of its trial steps lowered the energy but were cut for "
                       f"pushing contacts deeper than {depth_limit:.3g} into each other (the contact penalty "
                       f"may be too soft for these forces)") if too_deep else ""
                note = getattr(problem, "refusal", None)
                if refused and note:
                    why += f"; {refused} of its trial steps left the model ({note})"
                raise RelaxationError(f"relaxation stalled at iteration {it}: no decrease of "
                                      f"the energy along a damped Newton step (residual "
                                      f"{res:.3e}){why}", x, history)
        full_before = accepted and t == 1.0
        history.append((E, res, mu, t if accepted else 0.0, used, cap))
        if progress is not None:
            progress(it, E, res)
    if raise_on_failure:
        raise RelaxationError(f"relaxation: no convergence in {max_iter} iterations "
                              f"(residual {history[-1][1]:.3e} > {tol:.1e})", x, history)
    return Relaxed(x, E, float(problem.residual(g)), max_iter, False, history)
