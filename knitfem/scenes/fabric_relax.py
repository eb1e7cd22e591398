"""Relax a knitted swatch to a static equilibrium: the protocol.

From the knitted shape (stress-free at homotopy lam = 0) to the naturally
straight, pre-stretched yarn (lam = 1) in quasi-static increments:

1. each increment sets the natural strains at lam (:class:`Homotopy`) and
   minimises the total potential (elastic + contact + ties + friction) by
   damped, step-limited modified Newton (:mod:`knitfem.solve.minimize`,
   :mod:`knitfem.beam.energy`): every step lowers the energy and no node moves
   more than half a yarn radius, so no yarn can pass through another;
2. friction is *lagged*: its anchors (normal forces, frames, the set of
   touching points) are taken at the start of a round and kept while the
   round minimises; the next round (or increment) updates them, carrying each
   point's slip over (:mod:`knitfem.contact.friction`): contacts that formed
   during a round get their friction in the next (with ``reanchor``, off by
   default, a round ends early once enough contacts have formed, so they get
   it sooner: fewer steps, another path -- README, "re-anchoring as contacts
   form");
3. the increments on the way are solved to ``path_tol`` (1e-3), the last one
   to ``tol``; an increment grows after easy increments and is halved (from
   the last equilibrium and its friction anchors) when ``max_rounds`` rounds
   do not converge;
4. at lam = 1 rounds go on until a converged round moves no node more than
   ``creep`` (default 1e-3 r: the lagged normal forces have settled; a
   free-floating swatch's moves after the rigid motion that best carries one
   state onto the other, :func:`~.fabric_rounds.round_move`), or
   ``2 max_rounds`` rounds, the last of which converged; up to ``2 max_rounds``
   more while the rounds' final residuals keep halving (a contracting fixed
   point of the lagged friction: a smaller increment would only come back to
   the same rounds at lam = 1 -- seen on the 25 x 35, whose final rounds ended
   at 0.8, 0.26, 2e-3, 5e-4, 2e-5, 2e-6 against tol 1e-8);
5. any increment whose budget is spent while its last two rounds each moved
   the swatch more than a yarn radius is in a slide or a snap, not hovering
   at an equilibrium: it gets up to ``snap_rounds`` more rounds while that
   lasts, since a halved increment comes back to the same slide (the 25 x 35
   at alpha 0.1 near lam 0.79 moved 4.0, 4.9, 4.4 mm a round; the 55 x 35 at
   0.2 near 0.85 moved 6.1, 6.1, 25 r, failed three halvings and cost 6.5 h of
   failed attempts before ``--max-rounds 12`` was given by hand).

The answer is the last round's state: a static equilibrium of the undamped
forces (elastic, contact, ties and friction within its Coulomb cone),
relative residual <= ``tol`` against the model's fixed force scale, its
stability the inertia of its symmetric tangent (one sparse LDL^T), the
reaction at the held node ~0.  Nothing is returned as converged that is not;
a failed run raises :class:`FabricRelaxationError` keeping the last
equilibrium and the path.
"""
import time
from dataclasses import dataclass, field

import numpy as np

from ..beam.energy import EnergyProblem
from ..solve.minimize import SHIFTS, RelaxationError, minimize
from ..solve.stability import inertia, lowest_scaled_eigenvalue
from .fabric_rounds import (MAX_ROUNDS, SNAP_ROUNDS, another_round, round_move,
                            settle_pass_due, smallest_radius)

# the homotopy's first increment and the largest it grows to (relax_fabric's defaults)
DLAM, DLAM_MAX = 0.1, 0.25


class FabricRelaxationError(RuntimeError):
    """The relaxation failed; ``state`` is the last equilibrium (at ``lam``),
    ``increments`` the path so far."""

    def __init__(self, message, state, lam, increments):
        super().__init__(message)
        self.state, self.lam, self.increments = state, lam, list(increments)

    def __reduce__(self):
        return (type(self), (str(self), self.state, self.lam, self.increments))


@dataclass
class Increment:
    lam: float
    iterations: int
    residual: float
    energy: float
    min_gap: float          # smallest contact gap seen at the increment's states
    seconds: float
    accepted: bool = True   # False: an attempt that failed and was retried smaller
    moved: float = float("nan")   # largest node move of its last friction round (length)
    # the same measure from the state two rounds before the answer (nan: fewer
    # rounds in this process): small where ``moved`` is not, the rounds cycle
    # between two states (README, "a rigid turn and a two-round cycle")
    cycle: float = float("nan")


@dataclass
class FabricEquilibrium:
    state: object
    converged: bool
    residual: float
    stable: bool
    negative_eigenvalues: int
    reaction: float          # |reaction| at the held node over the force scale
    iterations: int          # all minimisation steps, failed attempts included
    increments: list = field(default_factory=list)     # accepted and failed (``accepted``)
    max_penetration: float = 0.0    # largest penetration along the path (length)
    coulomb_excess: float = 0.0     # friction force above mu f_n now, over the total
    penetration: float = 0.0        # penetration at the answer itself (length)
    lowest_eigenvalue: float = float("nan")   # of the diagonally scaled tangent
    # the lagged friction reached its fixed point: the last round (re-anchored
    # at the state before it) moved no node (nor turned a yarn's surface) more
    # than ``creep``, rigid motion of a free body aside (fabric_rounds.round_move);
    # False when the final increment ended on its round budget
    # instead (the answer is then an equilibrium for the last round's anchors,
    # and another round would move it)
    friction_settled: bool = None             # None: unknown (failed, or an older checkpoint)
    last_round_move: float = float("nan")     # length
    two_round_move: float = float("nan")      # length (Increment.cycle of the last)
    # the share of the contacts' push taken back at maxima of the distance, where
    # two contacts along one master yarn overlap (see knitfem.contact.narrow)
    overlap_share: float = 0.0


def _gap_watch(model, sink):
    """A minimize progress hook recording the smallest contact gap."""
    def hook(it, E, res):
        report = model.contact_model.report if model.contact_model is not None else None
        if report is not None:
            sink[0] = min(sink[0], report.min_gap)
    return hook


def _touching(contact):
    """The yarn segments in contact at the contact model's last evaluation
    (a boolean mask), None without a report."""
    report = contact.report
    if report is None or report.segment_gap is None:
        return None
    return report.segment_gap < contact.segments.law.g0


def _contacts_formed(contact, share, min_steps):
    """A minimize ``stop``: True once more segments have come into contact
    since the round began than ``share`` of those touching then (and more
    than 4), after ``min_steps`` steps.  Those contacts carry no friction until
    the next round anchors them, so the round is minimising a frictionless
    problem there: the yarns slide on along it and the round hovers (issue 9)."""
    start = [None]

    def stop(it, E, res):
        touching = _touching(contact)
        if touching is None:
            return False
        if it == 0:
            start[0] = touching
            return False
        if it < min_steps or start[0] is None:
            return False
        new = int(np.count_nonzero(touching & ~start[0]))
        return new > max(4, share * int(np.count_nonzero(start[0])))
    return stop


def _round(model, state, lam, tol, iterations, progress=None, reanchor=None, min_steps=10,
           exact_tries=SHIFTS):
    """One friction round: re-anchor (carrying slips) and minimise; with
    ``reanchor`` (a share, see :func:`_contacts_formed`) the round ends early,
    unconverged and ``stopped``, once that many new contacts have formed.
    ``exact_tries``: shifts of the exact Hessian tried before the PSD model
    (:func:`~knitfem.solve.minimize.minimize`'s ``shifts``)."""
    contact = model.contact_model
    if contact is not None:
        contact.anchor_friction(state.x, state.q)
    problem = EnergyProblem(model, 1.0)
    gap = [np.inf]
    hook = _gap_watch(model, gap)

    def both(it, E, res):
        hook(it, E, res)
        if progress is not None:
            progress(lam, it, E, res)
    stop = None
    if reanchor and contact is not None and contact.friction > 0.0:
        stop = _contacts_formed(contact, reanchor, min_steps)
    result = minimize(problem, state, tol=tol, max_iter=iterations, progress=both,
                      raise_on_failure=False, stop=stop, shifts=exact_tries)
    return result, gap[0]


@dataclass
class Partial:
    """An increment under way, after ``rounds`` friction rounds: its target
    lam, the state and friction anchors (``friction``, as
    :meth:`BeamContact.friction_state` gives them) after the last round, and
    the totals so far (and ``equilibrium``, the anchors of the equilibrium it
    started from, to retry from).  Written after every round, so a kill loses at most
    one round of an increment (one increment may be the whole relaxation)."""
    target: float
    state: object
    rounds: int
    iterations: int
    min_gap: float
    seconds: float
    friction: tuple = None       # after the last round
    equilibrium: tuple = None    # of the equilibrium at the increment's start
    ends: tuple = ()             # the rounds' final residuals (the extra rounds' test)
    moves: tuple = ()            # how far each round moved the swatch (length; the same)
    early: int = 0               # steps spent in rounds ended early (``reanchor``)


def _increment(model, state, lam, tol, iterations, max_rounds, creep, progress=None,
               min_rounds=1, start=None, on_round=None, extra_rounds=0, reanchor=None,
               snap_rounds=0, exact_tries=SHIFTS):
    """Friction rounds at lam until one converges (after at least
    ``min_rounds``) and moved no node more than ``creep`` (the lagged normal
    forces have settled), or ``max_rounds`` rounds of which the last
    converged; up to ``extra_rounds`` more while the rounds' final residuals
    or their moves keep shrinking (:func:`~.fabric_rounds.contracting`), up to
    ``snap_rounds`` more while each moves the swatch more than a yarn radius
    (:func:`~.fabric_rounds.sliding`; see :func:`~.fabric_rounds.another_round`).  With ``reanchor``
    a round may end early to anchor the contacts that formed in it
    (:func:`_contacts_formed`); such rounds do not count as rounds (nor
    in the shrinking test), and once they have spent ``max_rounds x
    iterations`` steps (kept across a resume) the increment's rounds run
    whole.  Returns (result, Increment) or (None, reason, Increment with
    accepted False: the work the failed attempt cost).  ``start``: a
    :class:`Partial` to continue; ``on_round(Partial)`` after every round
    that another may follow."""
    t = time.perf_counter()
    total, gap, result, first, before = 0, np.inf, None, 0, 0.0
    if start is not None:
        state, total, gap, first, before = (start.state, start.iterations, start.min_gap,
                                            start.rounds, start.seconds)
    contact = model.contact_model

    def failed(reason):
        return None, reason, Increment(lam, total, np.nan, np.nan, gap,
                                       before + time.perf_counter() - t, False)
    ends = list(start.ends) if start is not None else []
    moves = list(start.moves) if start is not None else []
    arm = smallest_radius(model) or 0.0
    free = model.free_floating                     # rounds measured without rigid motion
    early = start.early if start is not None else 0    # steps of rounds ended early
    k = first
    two_back, cycle = None, np.nan        # the state before the last round's start

    def more():
        return another_round(k, ends, moves, arm, max_rounds, extra_rounds, snap_rounds)
    while more():
        allow = reanchor if early < max_rounds * iterations else None
        try:
            result, g = _round(model, state, lam, tol, iterations, progress, allow,
                               exact_tries=exact_tries)
        except RelaxationError as err:
            total += len(err.history)
            return failed(f"round {k + 1} at lam = {lam:.4g}: {err}")
        total += result.iterations
        gap = min(gap, g)
        if result.stopped:
            early += result.iterations
            state = result.state
            if on_round is not None:
                on_round(Partial(lam, state, k, total, gap, before + time.perf_counter() - t,
                                 contact.friction_state() if contact is not None else None,
                                 ends=tuple(ends), moves=tuple(moves), early=early))
            continue
        ends.append(result.residual)
        moved = round_move(state, result.state, arm, free)
        moves.append(moved)
        cycle = round_move(two_back, result.state, arm, free) if two_back is not None else np.nan
        two_back, state = state, result.state
        if result.converged and (k >= min_rounds - 1) and moved <= creep:
            break
        k += 1
        # a checkpoint only where another round follows: one written after the
        # last round would resume into no round at all, without its result
        if on_round is not None and more():
            on_round(Partial(lam, state, k, total, gap, before + time.perf_counter() - t,
                             contact.friction_state() if contact is not None else None,
                             ends=tuple(ends), moves=tuple(moves), early=early))
    if result is None or not result.converged:
        residual = f"{result.residual:.2e}" if result is not None else "not computed"
        # rounds that each carry the swatch yarn radii on are not hovering at
        # an equilibrium: it is sliding, or snapping, somewhere far (25 x 35 at
        # alpha 0.1 near lam 0.79: 4.0, 4.9, 4.4 mm a round); a smaller
        # increment comes back to the same slide, more rounds may finish it
        slide = (f"; each of its {len(moves)} rounds moved the swatch {min(moves):.3g}-"
                 f"{max(moves):.3g} (more than a yarn radius; {snap_rounds} rounds beyond the "
                 f"budget of {max_rounds} allowed for that): a long slide or a snap, which more "
                 f"rounds an increment (--max-rounds, --snap-rounds) may finish"
                 if arm and len(moves) >= 2 and min(moves) > arm else "")
        return failed(f"no converged friction round at lam = {lam:.4g} in {k} rounds "
                      f"(residual {residual}){slide}")
    return result, Increment(lam, total, result.residual, result.energy, gap,
                             before + time.perf_counter() - t, True, moved, cycle)


def relax_fabric(model, homotopy, state=None, *, lam=0.0, tol=1e-8, path_tol=1e-3, dlam=DLAM,
                 dlam_max=DLAM_MAX, dlam_min=1e-3, iterations=200, max_rounds=MAX_ROUNDS, creep=None,
                 progress=None, checkpoint=None, partial=None, increments=(), reanchor=None,
                 snap_rounds=SNAP_ROUNDS, settle=0, exact_tries=SHIFTS):
    """Relax ``model`` from ``state`` (default its layout) at homotopy ``lam``
    to lam = 1 (see the module docstring).

    path_tol : relative residual of the increments on the way; tol : of the
    last one (the answer).  The way needs only to stay near the path: with
    1e-5 friction rounds stuck at 1e-4 (stick-slip) halved the increments to
    failure (4 x 4 at lam 0.45, the mirrored 5 x 5 at 0.37, alpha 0.05); with
    1e-3 both converge and a 5 x 5 takes 2 558 instead of 3 269 iterations,
    its rolls within 6 deg of the 1e-5 run's.  iterations : per friction round.
    progress(lam, iteration, E, residual) after every minimisation step;
    checkpoint(state, lam, dlam, increments, partial) after every increment
    (partial None) and after every friction round of an increment under way
    (partial a :class:`Partial`; the model's friction anchors are then the
    round's, those of the equilibrium at lam are ``partial.equilibrium``).
    To resume, pass state, lam, dlam, the partial and the increments so far
    back, with the equilibrium's anchors in the contact model.  reanchor :
    None (rounds run whole) or a share: a round ends early once the
    segments that came into contact in it exceed that share of those touching
    at its start (:func:`_contacts_formed`; see :func:`_increment` for how
    such rounds are counted).  snap_rounds : rounds an increment may take
    beyond ``max_rounds`` while each slides the swatch more than a yarn radius
    (0: none; the protocol before 2026-12-05).  settle : up to this many more
    passes of the final increment's rounds (each with its budget, re-anchored
    at the answer) while its friction has not settled; entered at lam = 1
    (a finished run's checkpoint) they are the only work done.  A pass that
    ends without a converged round leaves the answer before it (unsettled),
    its work recorded as a failed attempt; it counts as a pass
    (:func:`~.fabric_rounds.settle_passes`).  exact_tries : shifts of the exact
    Hessian a step tries (mu, 10 mu, ...) before the per-block PSD model
    (README: 'Fewer shifts of the exact Hessian').  Returns :class:`FabricEquilibrium`.
    """
    state = model.initial_state() if state is None else state
    if creep is None:
        radius = smallest_radius(model)
        creep = 1e-3 * radius if radius is not None else 1e-6 * model.length_scale()
    increments = list(increments)
    lam = float(lam)
    contact = model.contact_model
    # the slips carried from round to round are part of the equilibrium: a
    # failed increment must retry from the last equilibrium's anchors, not
    # from those its failed rounds left behind
    saved = contact.friction_state() if contact is not None else None
    while lam < 1.0 or partial is not None or settle_pass_due(increments, creep, settle):
        # snap: ten increments of 0.1 sum to 0.9999999999999999, which would
        # leave a round-off increment solved to path_tol before the last one
        target = 1.0 if lam + dlam > 1.0 - 1e-9 else lam + dlam
        # a settle pass: the final increment's rounds again, from its answer
        polish = lam >= 1.0
        if partial is not None:
            target = partial.target
            if contact is not None:
                contact.restore_friction(partial.friction)
        last = target == 1.0
        homotopy.apply(target)

        def on_round(p):
            if checkpoint is not None:
                p.equilibrium = saved
                checkpoint(state, lam, dlam, increments, p)
        result, inc, *attempt = _increment(model, state, target, tol if last else path_tol,
                                           iterations, 2 * max_rounds if last else max_rounds,
                                           creep if last else np.inf, progress,
                                           2 if last and not polish else 1, partial, on_round,
                                           2 * max_rounds if last else 0, reanchor,
                                           snap_rounds, exact_tries)
        partial = None
        if result is None:
            # the failed attempt's work counts (iterations, time), not its path
            increments.extend(attempt)
            if polish:
                # the answer stands, for its own anchors; unsettled, as reported
                # (checkpointed with the failed pass: a resume neither repeats
                # the pass nor loses its work)
                if contact is not None:
                    contact.restore_friction(saved)
                if checkpoint is not None:
                    checkpoint(state, lam, dlam, increments, None)
                break
            dlam = 0.5 * (target - lam)
            homotopy.apply(lam)
            if contact is not None:
                contact.restore_friction(saved)
            if dlam < dlam_min:
                raise FabricRelaxationError(
                    f"relaxation failed near homotopy lam = {target:.4g} (increment "
                    f"{target - lam:.2g} from the equilibrium at {lam:.4g}): {inc}", state, lam,
                    increments)
            continue
        increments.append(inc)
        state, lam = result.state, target
        if contact is not None:
            saved = contact.friction_state()
        if inc.iterations <= iterations:
            dlam = min(1.5 * dlam, dlam_max)
        if checkpoint is not None:
            checkpoint(state, lam, dlam, increments, None)
    eq = equilibrium(model, state, True, increments)
    final = [inc for inc in increments if inc.accepted and inc.lam == 1.0]
    if final and np.isfinite(final[-1].moved):
        eq.last_round_move = final[-1].moved
        eq.two_round_move = final[-1].cycle
        eq.friction_settled = bool(final[-1].moved <= creep)
    return eq


def equilibrium(model, state, converged, increments):
    """The answer at ``state``: residual, stability, reactions (with the friction
    anchors of the last increment in place)."""
    problem = EnergyProblem(model, 1.0)
    _, g, H, _ = problem.evaluate(state, True)
    contact = model.contact_model
    report = contact.report if contact is not None else None    # of that evaluation
    penetration = max(0.0, -report.min_gap) if report is not None else 0.0
    residual = problem.residual(g)
    negative = inertia(H)[0]
    _, f, _ = model.internal_forces(state, tangent=False)
    reaction = float(np.linalg.norm((f * model.residual_weights())[model.fixed]) / problem.ref)
    gaps = [inc.min_gap for inc in increments if inc.accepted and np.isfinite(inc.min_gap)]
    excess = contact.coulomb_excess(state.x, state.q) if contact is not None else 0.0
    push = report.total_normal_force + report.overlap_force if report is not None else 0.0
    return FabricEquilibrium(state, bool(converged), residual, negative == 0, int(negative),
                             reaction, int(sum(inc.iterations for inc in increments)),
                             increments, max(0.0, -min(gaps, default=0.0)), excess,
                             penetration, lowest_scaled_eigenvalue(H),
                             overlap_share=report.overlap_force / push if push > 0 else 0.0)
