"""FIRE: the accelerated relaxation (Bitzek et al. 2006; FIRE 2.0, Guénolé et al. 2020).

Damped dynamics that steers the velocity toward the force, v <- (1 - a) v +
a |v| F/|F|, lengthens the step while the power P = F . v stays positive and
stops dead (v = 0, shorter step, half a step back) when it turns negative.
On the same energy as dynamic relaxation, with fictitious masses: each
coordinate's mass is the absolute row sum of the Hessian (Gershgorin, so the
explicit step 1 is stable for every mode at once) instead of the yarn's
mass, which evens out the stiff stretching and the soft sliding and bending
of a knit.  The masses are refreshed when the step has had to shrink
``refresh`` times (the contact stiffness grows as yarns press in).  Only the
end state matters, so neither the masses nor the path are physical.

A relaxation can stop and go on: :class:`FireState` is everything carried
from one step to the next, so a run resumed from the state after step k takes
bit for bit the steps of one that never stopped (the energy is a function
of y alone).
"""
import time
from typing import NamedTuple
import warnings

import numpy as np

from .relax import (Relaxed, RelaxationError, converged, largest_move, progress_bar,
                    step_numbers)


class FireState(NamedTuple):
    """FIRE after ``step`` steps: positions y, velocities v, masses m, step dt,
    mixing a, the counters (steps of positive power, step cuts since the masses
    were set, capped steps, mass refreshes) and the residuals checked so far."""
    y: np.ndarray
    v: np.ndarray
    m: np.ndarray
    dt: float
    a: float
    n_pos: int
    cuts: int
    step: int
    capped: int
    refreshes: int
    history: tuple
    target: float = None     # the residual aimed at once ``confirm`` refused rest (None: rtol)

    def arrays(self):
        """The state as a dict of numpy arrays (for ``np.savez``)."""
        return {k: np.asarray(np.nan if v is None else v) for k, v in self._asdict().items()}

    @classmethod
    def from_arrays(cls, arrays):
        """The inverse of :meth:`arrays` (any mapping of the same keys)."""
        f = {k: arrays[k] for k in cls._fields if k != "target"}
        # checkpoints written before ``target`` existed aimed at their rtol
        target = float(arrays["target"]) if "target" in arrays else None
        target = None if target is not None and np.isnan(target) else target
        return cls(*(np.array(f[k], float) for k in ("y", "v", "m")),
                   float(f["dt"]), float(f["a"]),
                   *(int(f[k]) for k in ("n_pos", "cuts", "step", "capped", "refreshes")),
                   tuple(float(h) for h in np.atleast_1d(f["history"])), target)


def gershgorin_masses(model, y, floor=1e-12):
    """Absolute row sums of the (projected) reduced Hessian at y: with these
    masses the explicit step 1 is stable (eigenvalues of M^-1 K <= 1... 4)."""
    H = model.reduced_hessian(y, project=True)
    m = np.asarray(abs(H).sum(axis=1)).ravel()
    return np.maximum(m, floor * m.max())


def relax_fire(model, y0, *, rtol=1e-6, max_steps=200000, dt_max=1.0, n_delay=20,
               f_inc=1.1, f_dec=0.5, a_start=0.25, f_a=0.99, refresh=20, check_every=20,
               max_move=None, max_time=None, progress=False, monitor=None, state=None,
               checkpoint=None, checkpoint_every=600.0, confirm=None):
    """FIRE 2.0 to a relative residual ``rtol`` (:func:`.relax.converged`);
    :class:`Relaxed` (method "fire") or :class:`RelaxationError` with the
    last state after ``max_steps`` (None: no step limit; counted from the
    first step of a resumed run) or ``max_time`` seconds (this call's).  dt in
    units of the Gershgorin step (1 is stable); max_move: largest control-point
    move per step (default r/4 of the contact law: no yarn jumps through another
    between two force evaluations; the velocity is scaled down to keep it);
    monitor(step, y, residual, E, ke) at every check.  state: a
    :class:`FireState` to go on from (y0 is then ignored); checkpoint(state)
    is called at a check at most every ``checkpoint_every`` seconds and once
    more on the way out, however it ends (converged, a limit, an
    interruption: then with the state of the last check).

    confirm(y) -> bool: asked when the residual criterion holds whether y is
    at rest (e.g. :func:`.stability.equilibrium_distance` small enough); when
    it says no, FIRE goes on towards a ten times smaller residual (the
    state's ``target``) and asks again there.  A relative residual against the
    stiff stretching forces can leave a soft mode far from rest."""
    start = time.perf_counter()
    if max_move is None:
        contact = getattr(model, "contact", None)
        max_move = 0.25 * contact.radius if contact is not None else np.inf
    Z, _ = model.reduction()
    if state is None:
        y = np.asarray(y0, float).copy()
        m = gershgorin_masses(model, y)
        v = np.zeros_like(y)
        dt, a, n_pos, cuts, first, capped, refreshes, history = \
            0.5 * dt_max, a_start, 0, 0, 1, 0, 0, []
    else:
        if max_steps is not None and max_steps <= state.step:
            raise ValueError(f"max_steps must be > {state.step}, the steps the state was "
                             f"taken after (steps count from the first run's first), got "
                             f"{max_steps}")
        y, v, m = state.y.copy(), state.v.copy(), state.m.copy()
        dt, a, n_pos, cuts, capped, refreshes = (state.dt, state.a, state.n_pos, state.cuts,
                                                 state.capped, state.refreshes)
        first, history = state.step + 1, list(state.history)
    target = rtol if state is None or state.target is None else min(rtol, state.target)
    step = first - 1

    def snapshot():
        return FireState(y.copy(), v.copy(), m, dt, a, n_pos, cuts, step, capped, refreshes,
                         tuple(history), None if target == rtol else target)

    def aim():
        return "" if target == rtol else (f" (rtol {rtol:.1e} was reached, but confirm "
                                          f"refused rest there: aiming at {target:.1e})")

    def at_rest():
        nonlocal target
        if not converged(g, ref, target, model):
            return False
        if confirm is None or confirm(y):
            return True
        target = min(target, float(np.linalg.norm(g) / ref)) / 10.0
        return False

    last = snapshot() if state is None else state
    saved_at = start
    E, g, ref = model.reduced_energy(y)
    if state is not None and at_rest():
        # where an unbroken run stopped (a converged run's last checkpoint)
        return Relaxed(y, step, float(np.linalg.norm(g) / ref), E, "fire", history, dt, v,
                       report={"capped_steps": capped, "mass_refreshes": refreshes})
    bar = progress_bar(progress, max_steps, "FIRE", initial=first - 1)
    try:
        for step in step_numbers(max_steps, max_time, first):
            F = -g
            P = F @ v
            if P > 0:
                n_pos += 1
                if n_pos > n_delay:
                    dt = min(dt * f_inc, dt_max)
                    a *= f_a
            else:
                n_pos = 0
                if step > n_delay:
                    dt *= f_dec
                    a = a_start
                    cuts += 1
                y -= 0.5 * dt * v                   # half a step back, then stop
                v[:] = 0.0
                if cuts >= refresh:                 # stiffer than when the masses were set
                    m = gershgorin_masses(model, y)
                    dt, cuts = 0.5 * dt_max, 0
                    refreshes += 1
            v += dt * F / m
            vn, fn = np.sqrt(v @ (m * v)), np.sqrt(F @ (F / m))
            if P > 0 and fn > 0:
                v = (1.0 - a) * v + a * (vn / fn) * (F / m)
            move = dt * largest_move(Z, v)
            if move > max_move:
                v *= max_move / move
                capped += 1
            y += dt * v
            E, g, ref = model.reduced_energy(y)
            if not np.isfinite(E):
                raise RelaxationError(f"FIRE diverged at step {step}", y - dt * v, history,
                                      step)
            done = at_rest()
            if step % check_every == 0 or done:
                r = float(np.linalg.norm(g) / ref)
                history.append(r)
                last = snapshot()
                ke = 0.5 * float(v @ (m * v))
                if monitor is not None:
                    monitor(step, y, r, E, ke)
                if bar is not None:
                    bar.update(check_every)
                    bar.set_postfix(residual=f"{r:.1e}", dt=f"{dt:.2f}")
                if done:
                    return Relaxed(y, step, r, E, "fire", history, dt, v,
                                   report={"capped_steps": capped, "mass_refreshes": refreshes})
                now = time.perf_counter()
                if checkpoint is not None and now - saved_at >= checkpoint_every:
                    checkpoint(last)
                    saved_at = now
                if max_time is not None and now - start > max_time:
                    raise RelaxationError(f"FIRE reached its time limit {max_time:.0f} s at "
                                          f"step {step}, relative residual {r:.2e}{aim()}", y,
                                          history, step)
        last = snapshot()                           # the step limit: after its last step
    finally:
        if bar is not None:
            bar.close()
        if checkpoint is not None:
            try:
                checkpoint(last)
            except Exception as err:       # never at the cost of the answer or its error
                warnings.warn(f"FIRE: the last checkpoint was not written: {err}")
    raise RelaxationError(f"FIRE did not reach relative residual {rtol:.1e}"
                          f"{' at rest' if confirm is not None else ''} in "
                          f"{max_steps} steps (last {history[-1] if history else float('nan'):.2e})"
                          f"{aim()}", y, history, step)
