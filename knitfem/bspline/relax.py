"""Relaxation of a B-spline yarn model to static equilibrium.

* ``relax_dynamic`` - dynamic relaxation (the paper's method): explicit
  symplectic Euler on the lumped masses with mass-proportional damping
  (k_global), the contact law's normal/tangential damping, and/or kinetic
  damping (velocities zeroed at every peak of the kinetic energy, which
  removes energy far faster than viscosity).  The time
  step is 0.7 of the stability limit 2 / omega_max, omega_max^2 the largest
  eigenvalue of M^-1 K estimated by power iteration with Hessian-vector
  products from gradient differences; if the energy doubles (the stiffness
  grew, the step went unstable) it returns to its last checkpoint with half
  the step.
* ``relax_static`` - the faster, Newton-type option: L-BFGS (scipy) on the
  total energy with the exact gradient.

Both stop when the relative residual |dE/dy| / (sum of the separate force
sizes) falls below ``rtol`` (the dynamic one also needs the kinetic energy
below ``ke_rtol`` times the energy scale max(|E|, force size x yarn
length): at rest, not passing through equilibrium at speed), and raise
:class:`RelaxationError` (with the last state) when they run out of steps.
They find minima, i.e. stable equilibria.
"""
from dataclasses import dataclass, field
import itertools
import time

import numpy as np
from scipy.optimize import minimize

MAX_HALVINGS = 8     # of the explicit time step, when the dynamics goes unstable


class RelaxationError(RuntimeError):
    """Relaxation did not converge; ``y`` is the last state, ``history`` the
    relative residuals seen."""

    def __init__(self, message, y, history, iterations=None):
        super().__init__(message)
        self.y = y
        self.history = list(history)
        self.iterations = iterations      # steps taken, where the method counts them


@dataclass
class Relaxed:
    y: np.ndarray
    iterations: int
    residual: float                 # relative residual at the end
    energy: float
    method: str
    history: list = field(default_factory=list, repr=False)
    time_step: float = float("nan")     # dynamic relaxation: the explicit step it ended with
    velocity: np.ndarray = field(default=None, repr=False)   # explicit methods: at the end
    oscillations: int = 0               # standing oscillations ended on the way
    report: object = field(default=None, repr=False)


def step_numbers(max_steps, max_time, first=1):
    """The steps first, first + 1, ... of a relaxation: up to ``max_steps``, or
    without end (None) when a time limit ``max_time`` ends it instead."""
    if max_steps is None:
        if max_time is None:
            raise ValueError("max_steps: a relaxation needs a step limit (a positive integer) "
                             "or a time limit max_time; got neither")
        return itertools.count(first)
    return range(first, int(max_steps) + 1)


def progress_bar(progress, total, desc, initial=0):
    """A tqdm bar over ``total`` steps (a count and rate only, no percentage
    or ETA, when ``total`` is None) starting at ``initial`` (a resumed run's
    steps so far), or None when ``progress`` is off."""
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="step", leave=False, initial=initial)


def _residual(model, y):
    E, g, ref = model.reduced_energy(y)
    return E, g, float(np.linalg.norm(g) / max(ref, 1e-300))


def largest_move(Z, step):
    """The largest control-point move (length) of a step of the reduced
    coordinates: Z maps them to the control points (:meth:`reduction`)."""
    return float(np.sqrt(((Z @ step).reshape(-1, 3) ** 2).sum(axis=1)).max())


def converged(g, ref, rtol, model, atol=0.0):
    """|g| <= rtol ref, or <= atol (a force scale the caller fixes, for states
    whose forces all vanish), or below the model's round-off floor (a fixed
    scale of the problem: no state can do better than that)."""
    g = float(np.linalg.norm(g))
    return g <= max(rtol * ref, atol, getattr(model, "roundoff", 0.0))


def relax_static(model, y0, *, rtol=1e-6, max_iter=20000):
    """L-BFGS on the energy of the reduced coordinates."""
    history = []

    def fun(y):
        E, g, _ = model.reduced_energy(y)
        return E, g

    def stop(intermediate_result):
        _, g, ref = model.reduced_energy(intermediate_result.x)
        history.append(float(np.linalg.norm(g) / ref))
        if converged(g, ref, rtol, model):
            raise StopIteration

    result = minimize(fun, np.asarray(y0, float), jac=True, method="L-BFGS-B", callback=stop,
                      options={"maxiter": max_iter, "maxcor": 30, "gtol": 0.0, "ftol": 0.0})
    E, g, r = _residual(model, result.x)
    if not converged(g, model.reduced_energy(result.x)[2], rtol, model):
        raise RelaxationError(f"L-BFGS stopped after {result.nit} iterations with relative "
                              f"residual {r:.2e} > {rtol:.1e} ({result.message})",
                              result.x, history)
    return Relaxed(result.x, result.nit, r, E, "static (L-BFGS)", history)


def stable_time_step(model, y, masses, iterations=60, rng=None, safety=0.7):
    """safety * 2 / omega_max for the explicit scheme (power iteration on
    M^-1 K, which approaches omega_max^2 from below, hence the margin; the
    stiffness also grows as the yarn moves).  K: the model's Hessian when it
    has one, else central differences of the gradient."""
    rng = np.random.default_rng(0) if rng is None else rng
    v = rng.normal(size=y.shape)
    v /= np.linalg.norm(v)
    if hasattr(model, "reduced_hessian"):
        H = model.reduced_hessian(y)

        def K(v):
            return H @ v
    else:
        eps = 1e-7 * max(1.0, np.linalg.norm(y) / np.sqrt(y.size))

        def K(v):
            return (model.reduced_energy(y + eps * v)[1]
                    - model.reduced_energy(y - eps * v)[1]) / (2 * eps)
    lam = 0.0
    for _ in range(iterations):
        w = K(v) / masses
        lam = float(np.linalg.norm(w))
        v = w / lam
    return safety * 2.0 / np.sqrt(lam)


class Oscillation:
    """Detects a standing oscillation of damped dynamics: over ``patience``
    checks the mechanical energy E + KE has fallen by less than ``tol`` of
    itself while the kinetic energy kept rising and falling (at least two
    valleys): the damping is not getting anywhere and the state is not at
    rest.  :meth:`check` says when to end it; ``resets`` counts them."""

    def __init__(self, patience=50, tol=1e-4):
        self.patience, self.tol = patience, tol
        self.window = []
        self.valleys = 0
        self.trend = 0.0
        self.last_ke = 0.0
        self.resets = 0

    def check(self, E, ke):
        if ke > self.last_ke and self.trend < 0:
            self.valleys += 1
        self.trend, self.last_ke = ke - self.last_ke, ke
        self.window.append(E + ke)
        if len(self.window) < self.patience:
            return False
        first, now = self.window[0], self.window[-1]
        standing = first - now < self.tol * abs(first) and self.valleys >= 2
        self.window, self.valleys = [], 0
        if standing:
            self.resets += 1
        return standing


def relax_dynamic(model, y0, *, rtol=1e-6, ke_rtol=1e-12, max_steps=200000, dt=None,
                  damping=0.0, kinetic=True, check_every=20, progress=False, max_time=None,
                  patience=50, monitor=None):
    """Damped explicit dynamics to rest.  damping: mass-proportional coefficient
    (1/time: the paper's k_global per unit mass); kinetic: kinetic damping;
    contact damping comes with the model's contact law.  A standing
    oscillation (:class:`Oscillation`: ``patience`` checks in which the
    mechanical energy hardly fell while the kinetic energy oscillated) is
    ended by kinetic damping (velocities zeroed at every peak of the kinetic
    energy) for the next ``patience`` checks.  After ``max_time`` seconds or
    ``max_steps`` (None: no step limit) the relaxation gives up
    (:class:`RelaxationError`, last state kept).  monitor(step, y, residual, E, ke) is called at every check."""
    for name, value in (("rtol", rtol), ("ke_rtol", ke_rtol), ("damping", damping)):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be finite and in [0, inf), got {value!r}")
    start = time.perf_counter()
    y = np.asarray(y0, float).copy()
    m = model.masses()
    dt = stable_time_step(model, y, m) if dt is None else float(dt)
    length = float(np.sum(model.rest))         # energy scale: force size x yarn length
    contact = getattr(model, "contact", None)
    dissipative_contact = contact is not None and contact.dissipates
    v = np.zeros_like(y)
    ke = ke_last = 0.0
    history = []
    watch = Oscillation(patience)
    kinetic_until = 0                           # kinetic damping on until this step
    bar = progress_bar(progress, max_steps, "dynamic relaxation")
    # the stiffness grows as the yarn bends, so the step estimated at the start can
    # turn unstable later: damped dynamics never gains energy, so a state whose
    # energy has doubled since the last checkpoint sends us back there with half the step
    checkpoint, E_checkpoint, halvings = y.copy(), np.inf, 0
    try:
        for step in step_numbers(max_steps, max_time):
            with np.errstate(all="ignore"):
                if dissipative_contact:
                    E, g, ref, f_contact = model.reduced_forces(y, v)
                else:
                    E, g, ref = model.reduced_energy(y)
            if step % check_every == 0:
                r = float(np.linalg.norm(g) / max(ref, 1e-300))
                history.append(r)
                if monitor is not None:
                    monitor(step, y, r, E, ke)
                if bar is not None:
                    bar.update(check_every)
                    bar.set_postfix(residual=f"{r:.1e}")
                if not (np.isfinite(r) and np.isfinite(E)) or E > E_checkpoint + abs(E_checkpoint):
                    halvings += 1
                    if halvings > MAX_HALVINGS:
                        raise RelaxationError(f"dynamic relaxation diverged at step {step} even "
                                              f"with the time step halved {MAX_HALVINGS} times "
                                              f"(now {dt:.3g})", checkpoint, history)
                    y, v, dt = checkpoint.copy(), np.zeros_like(v), 0.5 * dt
                    ke = ke_last = 0.0
                    continue
                if E <= E_checkpoint:
                    checkpoint, E_checkpoint = y.copy(), E
                # at rest, not passing through equilibrium (ke: of the step that led here)
                if converged(g, ref, rtol, model) and ke <= ke_rtol * max(abs(E), ref * length):
                    return Relaxed(y, step, r, E, "dynamic", history, dt, v, watch.resets)
                if watch.check(E, ke):          # end the standing oscillation
                    kinetic_until = step + patience * check_every
                if max_time is not None and time.perf_counter() - start > max_time:
                    raise RelaxationError(f"dynamic relaxation reached its time limit "
                                          f"{max_time:.0f} s at step {step}, relative residual "
                                          f"{r:.2e}", y, history)
            f = -g - damping * m * v
            if dissipative_contact:
                f += f_contact
            v += dt * f / m
            ke = 0.5 * np.sum(m * v * v)
            if (kinetic or step < kinetic_until) and ke < ke_last:    # past a kinetic peak
                v[:] = 0.0
                ke = 0.0
            ke_last = ke
            y += dt * v
    finally:
        if bar is not None:
            bar.close()
    raise RelaxationError(f"dynamic relaxation did not reach relative residual {rtol:.1e} in "
                          f"{max_steps} steps (last {history[-1]:.2e})", y, history)
