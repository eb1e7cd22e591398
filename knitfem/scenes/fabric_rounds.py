"""How many friction rounds an increment of the fabric relaxation may take.

The relaxation (:mod:`knitfem.scenes.fabric_relax`) solves each homotopy
increment by rounds of lagged friction.  An increment whose rounds have not
converged after its budget is halved -- unless its rounds show that a smaller
increment would only come back to the same rounds: they contract towards a
fixed point (:func:`contracting`), or each carries the swatch on by more than
a yarn radius, a slide or a snap under way (:func:`sliding`).  These
predicates read only the rounds' final residuals and moves (lengths, mm),
so they are tested on recorded sequences without a model.
"""
import numpy as np

# friction rounds an increment may take before it is halved (twice that at lam = 1)
MAX_ROUNDS = 4
# rounds beyond those while every round slides the swatch more than a yarn radius
SNAP_ROUNDS = 8


def round_move(old, new, arm, free):
    """How far a friction round moved the swatch from state ``old`` to ``new``
    (``.x`` positions (n, 3), ``.q`` frames (n, 4)): the largest change of a
    node's coordinate or of a point on a yarn's surface (frame turn x ``arm``,
    the yarn radius: a round that only turns frames has not settled either).
    ``free``: a free-floating scene, measured after the rigid motion that best
    carries ``old`` onto ``new`` -- its swatch, held at one node, turns about
    it along a near-zero mode by whatever the round's residual leaves (a 25 x
    35 round at alpha 0.3: a 0.022 deg turn; this measure 0.033 r without the
    fit, 0.0072 r with it), which is no change of the answer."""
    from ..beam.rotation import quat_multiply, spatial_turn

    def move(x_old, q_old):
        turned = np.linalg.norm(spatial_turn(new.q, q_old), axis=1)
        return max(float(np.max(np.abs(new.x - x_old))), arm * float(np.max(turned, initial=0.0)))
    x_old, q_old = np.asarray(old.x, float), np.asarray(old.q, float)
    moved = move(x_old, q_old)
    if not free or moved == 0.0:
        return moved
    from ..analysis.shape_change import rigid_fit
    rotation, c_old, c_new = rigid_fit(x_old, new.x)
    turn = np.roll(rotation.as_quat(), 1)               # scipy's (x, y, z, w) -> (w, x, y, z)
    # the fit minimises the mean square, not the largest move: never above no fit
    return min(moved, move(rotation.apply(x_old - c_old) + c_new,
                           quat_multiply(np.broadcast_to(turn, q_old.shape), q_old)))


def smallest_radius(model):
    """The thinnest yarn's radius (length), None if no rod has a finite one."""
    radii = [r.section.radius for r in model.rods if np.isfinite(r.section.radius)]
    return min(radii) if radii else None


def contracting(ends, moves=()):
    """The lagged friction's rounds still converge: each of the last two ended
    with at most half the residual of the one before (rounds that run out of
    steps), or moved the swatch at most 0.7 times as far as the one before
    (converged rounds nearing the fixed point: on the 3 x 4 test swatch the
    final rounds moved 1.7, 0.34, 0.082, 0.035, 0.010 r, on one thread 1.8,
    0.97, 0.39 r, and the round budget ended them above the 1e-3 r that
    counts as settled)."""
    def shrinking(v, rate):
        return len(v) >= 3 and v[-1] <= rate * v[-2] and v[-2] <= rate * v[-3] and v[-3] > 0
    return shrinking(ends, 0.5) or shrinking(moves, 0.7)


def sliding(moves, arm):
    """The last two rounds each moved the swatch more than ``arm`` (a yarn
    radius): a slide or a snap under way, not rounds hovering at an
    equilibrium (those move a fraction of a radius: 0.3-0.05 r on the 10 x 35)."""
    return arm > 0 and len(moves) >= 2 and min(moves[-2:]) > arm


def another_round(k, ends, moves, arm, max_rounds, extra_rounds=0, snap_rounds=0):
    """After ``k`` counted rounds (final residuals ``ends``, moves ``moves``)
    of an increment that has not ended: does another follow?  The budget is
    ``max_rounds``; up to ``extra_rounds`` more while the rounds contract
    (:func:`contracting`), up to ``snap_rounds`` more while they slide
    (:func:`sliding`)."""
    return (k < max_rounds
            or (k < max_rounds + extra_rounds and contracting(ends, moves))
            or (k < max_rounds + snap_rounds and sliding(moves, arm)))


def settle_passes(increments):
    """Settle passes run so far: the increments at lam = 1 recorded after the
    first accepted one, failed passes included (``increments``: the
    :class:`~.fabric_relax.Increment` records)."""
    final = [i for i, inc in enumerate(increments) if inc.lam == 1.0 and inc.accepted]
    return sum(inc.lam == 1.0 for inc in increments[final[0] + 1:]) if final else 0


def settle_pass_due(increments, creep, settle):
    """At lam = 1, does another pass of the final increment's friction rounds
    follow?  Yes while the last accepted lam-1 increment ended on its round
    budget with its last round moving more than ``creep`` (the friction not
    settled) and fewer than ``settle`` passes have run (:func:`settle_passes`;
    a failed pass counts: with the same budget it would fail again)."""
    final = [inc for inc in increments if inc.accepted and inc.lam == 1.0]
    return (bool(final) and settle_passes(increments) < settle
            and np.isfinite(final[-1].moved) and final[-1].moved > creep)


def settle_due_after(summary, settle):
    """Are settle passes due for a finished run, read from its summary (a
    ``knitfem curl`` JSON): its friction did not settle and it has run fewer
    than ``settle`` passes (the summary's view of :func:`settle_pass_due`)."""
    return (summary.get("friction_settled") is False
            and (summary.get("settle_passes") or 0) < (settle or 0))
