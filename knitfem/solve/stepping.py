"""Incremental loading: Newton at a sequence of load factors, cutting steps on failure.

Generic: ``problem_at(lam)`` returns a Newton problem (see
:mod:`knitfem.solve.newton`) for the load factor ``lam``.  If that problem has
``extrapolate(x_prev, x, factor)`` (the state reached by repeating the last
increment ``factor`` times), each step first tries that secant predictor and
falls back to the last equilibrium when Newton fails from it.  If it has
``begin_increment(lam_prev, x_prev)``, that is called before each increment
(rate-dependent terms such as contact damping need where the step started).

Every returned equilibrium carries its stability: the inertia of the symmetric
part of the Jacobian there (one sparse LDL^T, :mod:`knitfem.solve.factor`),
``stable`` when no eigenvalue is negative.  With ``require_stable`` an
increment that lands on an unstable equilibrium counts as failed and is cut,
so a large step cannot silently jump onto an unstable branch.
"""
from dataclasses import dataclass, field

from .newton import NewtonError, newton
from .stability import inertia


MAX_EXTRAPOLATION = 2.0   # never extrapolate the last increment more than twice


class SteppingError(NewtonError):
    """Load stepping failed.  ``steps`` holds the converged steps so far."""

    def __init__(self, reason, message, state, history, steps):
        super().__init__(reason, message, state, history)
        self.steps = steps

    def __reduce__(self):
        return (type(self), (self.reason, str(self), self.state, self.history, self.steps))


@dataclass
class Step:
    load: float
    state: object
    iterations: int                              # Newton iterations, all sub-steps
    history: list = field(default_factory=list)  # relative residuals, last sub-step
    substeps: int = 1
    roundoff_limited: bool = False               # stopped at the residual's noise floor
    report: object = None                        # the model's account of the state (e.g. contact)
    stable: bool = None                          # no negative eigenvalue (None: not checked)
    negative_eigenvalues: int = None             # index of the equilibrium


def equilibrium_index(problem, x):
    """Number of negative eigenvalues of sym(J) at the equilibrium x."""
    _, J, _ = problem.evaluate(x, True)
    return inertia(J)[0]


def load_stepping(problem_at, x0, loads, *, start=0.0, max_halvings=8, stability=True,
                  require_stable=False, **newton_options):
    """Follow the equilibrium path through the load factors ``loads``, starting
    from ``x0`` at load ``start`` (an equilibrium there, or a guess for it).

    A failed increment is halved (up to ``max_halvings`` times in a row) and
    doubled again after each converged sub-step.  ``stability``: label every
    returned step with its inertia; ``require_stable``: an unstable landing is a
    failed increment (cut), and the path ends with SteppingError(reason
    'unstable') if cutting does not help.  Returns one :class:`Step` per
    requested load; raises :class:`SteppingError` keeping the steps done and
    the last converged state.
    """
    stability = stability or require_stable
    steps = []
    x = x0
    lam = float(start)
    previous = None          # (load, state) of the equilibrium before x
    for target in loads:
        dlam, iterations, halvings, substeps = target - lam, 0, 0, 0
        while True:
            trial = target if abs(target - lam) <= abs(dlam) else lam + dlam
            problem = problem_at(trial)
            if hasattr(problem, "begin_increment"):
                problem.begin_increment(lam, x)
            guesses = [x]
            if previous is not None and hasattr(problem, "extrapolate"):
                ratio = (trial - lam) / (lam - previous[0])
                if 0.0 < ratio <= MAX_EXTRAPOLATION:
                    guesses.insert(0, problem.extrapolate(previous[1], x, ratio))
            result = err = None
            index = None
            for guess in guesses:          # the predictor first, the last equilibrium if it fails
                try:
                    result = newton(problem, guess, where=f"load {trial:.6g}", **newton_options)
                except NewtonError as e:
                    err = e
                    continue
                if not stability:
                    break
                index = equilibrium_index(problem, result.state)
                if index == 0 or not require_stable:
                    break
                err = NewtonError("unstable", f"the equilibrium reached at load {trial:.6g} is "
                                  f"unstable ({index} negative eigenvalue(s) of the tangent)",
                                  result.state, result.history)
                result = None
            if result is None:
                halvings += 1
                if halvings > max_halvings:
                    raise SteppingError(err.reason, f"{err}; the step from load {lam:.6g} "
                                        f"failed after {max_halvings} halvings", x,
                                        err.history, steps) from None
                dlam *= 0.5
                continue
            previous = (lam, x)
            x, lam = result.state, trial
            iterations += result.iterations
            substeps += 1
            if lam == target:
                break
            dlam, halvings = 2.0 * dlam, 0     # a sub-step worked: try a longer one next
        steps.append(Step(target, x, iterations, result.history, substeps,
                          result.roundoff_limited, stable=None if index is None else index == 0,
                          negative_eigenvalues=index))
    return steps
