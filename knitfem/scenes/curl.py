"""Fabric curling: relax a plain-knit swatch and classify its curl (paper Sec. 6).

    knitfem curl --nw 10 --nc 35 [--alpha 0.2] [--w 4 --c 3 --radius 0.4]
                 [--elements-per-loop 32] [--gj-over-ei X] [--ea-over-ei X]
                 [--friction 0.3] [--bindoff-stiffness 10] [--bindoff-prestretch]
                 [--out DIR]
                 [--json FILE] [--resume] [--no-render] [--quiet]

:func:`curl` builds the scene (:mod:`knitfem.scenes.fabric`), relaxes it
(:mod:`knitfem.scenes.fabric_relax`), classifies the relaxed shape
(:mod:`knitfem.analysis.curl`) and returns a JSON-ready dict.  With ``out`` it
writes the relaxation path (one .vtu per increment + ``path.pvd``, contact
data included), ``curl_<nw>x<nc>.vtu`` (the equilibrium), renders from three
views and a checkpoint after every increment (``checkpoint.npz``, written
atomically) from which ``resume`` continues after a kill.
"""
import json
import os
import time
from dataclasses import MISSING, astuple, fields
from pathlib import Path

import numpy as np

from ..io.atomic import write_json
from ..io.run import source
from .fabric import FabricScene, Homotopy, build, yarn_axial_strain
from .fabric_relax import FabricRelaxationError, Increment, relax_fabric
from .fabric_rounds import SNAP_ROUNDS, settle_passes

VIEWS = {"front": (0.0, 0.0, 1.0), "side": (1.0, 0.0, 0.0), "iso": (1.0, -1.0, 0.8)}


INCREMENT_FIELDS = tuple(f.name for f in fields(Increment))


def increments_of(data, path="checkpoint"):
    """The :class:`Increment` rows of a checkpoint, read by the column names it
    carries; one written before it carried them is read by position (columns
    were only ever appended: six, then ``accepted``, ``moved``, ``cycle``), the
    columns it lacks at their defaults.  A column this code does not know is
    refused by name (a newer checkpoint), never read into another field."""
    rows = np.asarray(data["increments"], float)
    rows = rows.reshape(len(rows), -1) if rows.size else np.zeros((0, len(INCREMENT_FIELDS)))
    names = ([str(n) for n in data["increment_fields"]] if "increment_fields" in data
             else list(INCREMENT_FIELDS[:rows.shape[1]]))
    columns = fields(Increment)
    required = [f.name for f in columns if f.default is MISSING]
    wrong = (sorted(set(names) - set(INCREMENT_FIELDS)) or len(set(names)) != len(names) or
             len(names) != rows.shape[1] or not set(required) <= set(names))
    if wrong:
        raise ValueError(f"{path}: its {rows.shape[1]} increment columns ({', '.join(names)}) "
                         f"are not this code's ({', '.join(INCREMENT_FIELDS)}; at least "
                         f"{', '.join(required)}): a checkpoint of another version")
    kinds = {f.name: f.type for f in columns}
    cast = {int: int, bool: bool}
    return [Increment(**{n: cast.get(kinds[n], float)(v) for n, v in zip(names, row)})
            for row in rows]


def _save_checkpoint(path, scene, state, lam, dlam, increments, contact, partial=None, *,
                     protocol=None):
    """Atomically write the relaxation's state after an increment, or after a
    friction round of the increment under way (``partial``); ``protocol``: the
    relaxation options the run was given (its snap-round budget always
    written: a checkpoint without one predates it, and ran none)."""
    protocol = dict(protocol or {})
    protocol.setdefault("snap_rounds", SNAP_ROUNDS)
    data = {"x": state.x, "q": state.q, "lam": lam, "dlam": dlam,
            "scene": json.dumps(scene.as_dict(), sort_keys=True),
            "protocol": json.dumps(protocol, sort_keys=True),
            "increments": np.array([astuple(i) for i in increments]),
            "increment_fields": np.array(INCREMENT_FIELDS)}
    anchors = [("", partial.equilibrium if partial is not None else
                (contact.friction_state() if contact is not None else None))]
    if partial is not None:
        data.update(partial_x=partial.state.x, partial_q=partial.state.q,
                    partial_numbers=np.array([partial.target, partial.rounds, partial.iterations,
                                              partial.min_gap, partial.seconds]),
                    partial_ends=np.array(partial.ends, dtype=float),
                    partial_moves=np.array(partial.moves, dtype=float),
                    partial_early=np.array(partial.early))
        anchors.append(("partial_", partial.friction))
    for prefix, friction in anchors:
        if friction is not None and friction[0] is not None:
            for name, value in friction[0]._asdict().items():
                data[prefix + "anchor_" + name] = value
            data[prefix + "anchor_q"] = friction[1]
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **data)
    os.replace(tmp, path)


def checkpoint_scene(data):
    """The :class:`FabricScene` a checkpoint (its loaded npz) was written for."""
    return FabricScene.stored(json.loads(str(data["scene"])))


# relaxation options a resume may change: budgets, which decide only what an
# increment that has used up the old one does next (the change is recorded)
BUDGETS = ("max_rounds", "snap_rounds", "settle")
# a budget's value where a protocol does not name it, when that is not
# relax_fabric's default (None): checkpoints name their snap rounds
BUDGET_DEFAULTS = {"snap_rounds": SNAP_ROUNDS}


def _path_protocol(protocol):
    return {k: v for k, v in (protocol or {}).items()
            if k not in BUDGETS and k != "budget_changes"}


def checkpoint_protocol(data):
    """The relaxation protocol a checkpoint (its loaded npz) was written with,
    its budget changes (``budget_changes``) included; {} for the defaults.
    One written before snap rounds existed (2026-12-05) ran none."""
    protocol = json.loads(str(data["protocol"])) if "protocol" in data.files else {}
    protocol.setdefault("snap_rounds", 0)
    return protocol


def resumed_protocol(kept, given, lam):
    """The protocol a resumed run records: ``given``, with every change of a
    budget against the checkpoint's ``kept`` protocol listed under
    ``budget_changes`` (the homotopy lam of the resume, the option, old and
    new value; None = relax_fabric's default), those made before included."""
    changes = list((kept or {}).get("budget_changes", []))
    for key in BUDGETS:
        old = (kept or {}).get(key, BUDGET_DEFAULTS.get(key))
        new = (given or {}).get(key, BUDGET_DEFAULTS.get(key))
        if old != new:
            changes.append({"lam": lam, "option": key, "from": old, "to": new})
    record = dict(_path_protocol(given), **{k: given[k] for k in BUDGETS if k in (given or {})})
    if changes:
        record["budget_changes"] = changes
    return record


def check_same_run(path, saved_scene, saved_protocol, scene, protocol):
    """ValueError unless what ``path`` holds (a checkpoint, or a finished
    path's summary) was run with ``scene`` and the path part of ``protocol``."""
    saved, given = saved_scene.as_dict(), scene.as_dict()
    if json.dumps(saved, sort_keys=True) != json.dumps(given, sort_keys=True):
        differ = ", ".join(f"{k}: checkpoint {saved[k]!r}, given {given[k]!r}"
                           for k in sorted(saved) if saved[k] != given[k])
        raise ValueError(f"--resume: {path} holds a run with other parameters ({differ}); "
                         "remove it or give the same options")
    # the protocol decides the path, and with it the answer (README, --reanchor);
    # a round budget may change (recorded: resumed_protocol)
    kept = _path_protocol(saved_protocol)
    if json.dumps(kept, sort_keys=True) != json.dumps(_path_protocol(protocol),
                                                      sort_keys=True):
        raise ValueError(f"--resume: {path} holds a run with another relaxation protocol "
                         f"(checkpoint {kept}, given {protocol or {}}); remove it or give the "
                         "same options")


def load_checkpoint(path, scene, model, protocol=None):
    """(state, lam, dlam, increments, partial) from a checkpoint of the same
    scene and relaxation ``protocol`` (options; a checkpoint from before they
    were kept ran the defaults), or None; the contact model gets the
    equilibrium's friction anchors."""
    from ..beam.model import BeamState
    from ..contact.friction import Anchors
    from .fabric_relax import Partial
    if not path.exists():
        return None
    data = np.load(path)
    check_same_run(path, checkpoint_scene(data), checkpoint_protocol(data), scene, protocol)

    def friction(prefix):
        if prefix + "anchor_key" not in data.files:
            return None, None
        return (Anchors(*(data[prefix + "anchor_" + f] for f in Anchors._fields)),
                data[prefix + "anchor_q"])
    contact = model.contact_model
    if contact is not None and "anchor_key" in data.files:
        contact.restore_friction(friction(""))
    increments = increments_of(data, path)
    partial = None
    if "partial_x" in data.files:
        target, rounds, iterations, gap, seconds = data["partial_numbers"]
        partial = Partial(float(target), BeamState(data["partial_x"], data["partial_q"]),
                          int(rounds), int(iterations), float(gap), float(seconds),
                          friction("partial_"),
                          ends=tuple(data["partial_ends"]) if "partial_ends" in data.files else (),
                          moves=tuple(data["partial_moves"]) if "partial_moves" in data.files
                          else (),
                          early=int(data["partial_early"]) if "partial_early" in data.files
                          else 0)
    return (BeamState(data["x"], data["q"]), float(data["lam"]), float(data["dlam"]),
            increments, partial)


def curl(scene, *, out=None, render=True, progress=True, resume=False, relax_options=None):
    """Relax the :class:`FabricScene` ``scene`` and classify its curl; returns the
    summary dict (see the README's fabric section for the keys).

    ``relax_options``: keyword arguments of :func:`relax_fabric` (budgets,
    tolerances).  A failed relaxation returns ``"curl": None`` and
    ``"converged": False`` with the error; the shape of the last equilibrium
    (at homotopy ``lam`` < 1, not the swatch's answer) is kept apart under
    ``"last_equilibrium"``."""
    from ..analysis.curl import swatch_curl
    from ..analysis.profile import profile_fields
    t0 = time.perf_counter()
    source()            # the commit that runs: cached now, not when the answer is written
    model, swatch, info = build(scene)
    homotopy = Homotopy.of_scene(model, scene)
    out = Path(out) if out is not None else None
    checkpoint_path = out / "checkpoint.npz" if out is not None else None
    start = kept = None
    if out is not None:
        (out / "path").mkdir(parents=True, exist_ok=True)
        if resume:
            start = load_checkpoint(checkpoint_path, scene, model, relax_options)
            if start is not None:
                kept = checkpoint_protocol(np.load(checkpoint_path))
                relax_options = resumed_protocol(kept, relax_options, start[1])
        elif checkpoint_path.exists():
            checkpoint_path.unlink()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=1000, desc=f"curl {scene.nw}x{scene.nc}", unit="", leave=False,
                   bar_format="{desc} {percentage:3.0f}% |{bar}| {elapsed} {postfix}")

    def on_step(lam, it, E, res):
        if bar is not None:
            bar.n = int(1000 * lam)
            bar.set_postfix_str(f"lam={lam:.3f} it={it} res={res:.1e}", refresh=True)

    frames = []
    # accepted increments whose step is written (a failed settle pass is
    # checkpointed too, with no new step)
    written = [sum(inc.accepted for inc in start[3]) if start is not None else 0]

    def on_increment(state, lam, dlam, increments, partial=None):
        if out is None:
            return
        step = sum(inc.accepted for inc in increments)
        if partial is None and step > written[0]:
            from ..io import write_beam_state
            written[0] = step
            frames.append((write_beam_state(out / "path" / f"step_{step:03d}.vtu",
                                            model, state), lam))
        _save_checkpoint(checkpoint_path, scene, state, lam, dlam, increments,
                         model.contact_model, partial, protocol=relax_options)

    kwargs = {}
    if start is not None:
        state, lam, dlam, done, partial = start
        # the path written before the resume stays in path.pvd (step k is
        # the k-th accepted increment's equilibrium)
        steps = ((out / "path" / f"step_{k:03d}.vtu", inc.lam)
                 for k, inc in enumerate((inc for inc in done if inc.accepted), 1))
        frames.extend((f, t) for f, t in steps if f.exists())
        kwargs = dict(state=state, lam=lam, dlam=dlam, partial=partial, increments=done)
        homotopy.apply(lam)
    failure = None
    try:
        # a resumed run goes on with the checkpoint's step, not the options' first one
        eq = relax_fabric(model, homotopy, progress=on_step, checkpoint=on_increment,
                          **{**{k: v for k, v in (relax_options or {}).items()
                                if k != "budget_changes"}, **kwargs})
    except FabricRelaxationError as err:
        failure = err
    finally:
        if bar is not None:
            bar.close()
    if failure is not None:
        from .fabric_relax import equilibrium
        eq = equilibrium(model, failure.state, False, failure.increments)
    elif start is not None and start[4] is None and len(eq.increments) == len(start[3]):
        # a finished run re-reported: budgets given now changed nothing, so
        # none is recorded as changed (the checkpoint's protocol stands)
        relax_options = {k: v for k, v in kept.items()
                         if not (k == "snap_rounds" and v == SNAP_ROUNDS)} or None
    shape = swatch_curl(eq.state.x, swatch)
    fields_ = {
        "curl": shape.curl, "edges_touch": bool(shape.edges_touch),
        "roll_deg": {k: float(v) for k, v in shape.roll_deg.items()},
        "curvature_x": shape.curvature_x, "curvature_y": shape.curvature_y,
        "height_over_width": shape.height_over_width, "height": shape.height,
        "loop_aspect": shape.loop_aspect, **profile_fields(eq.state.x, swatch)}
    if failure is not None:
        # a half-relaxed swatch is not the answer: its shape is kept, labelled
        fields_ = {"last_equilibrium": dict(fields_, lam=failure.lam),
                   **{k: None for k in fields_}}
    summary = {
        "nw": scene.nw, "nc": scene.nc, "model": "beam", "alpha": scene.alpha, **fields_,
        "converged": bool(eq.converged), "residual": eq.residual, "stable": bool(eq.stable),
        # the minimised potential at the answer (N mm: elastic, contact, and the
        # last friction round's, ~0 once the friction settled)
        "energy": (next((inc.energy for inc in reversed(eq.increments) if inc.accepted), None)
                   if failure is None else None),
        "negative_eigenvalues": eq.negative_eigenvalues,
        "lowest_eigenvalue": eq.lowest_eigenvalue,
        "max_penetration_over_d": eq.max_penetration / (2.0 * scene.radius),
        # the answer's own (the key above is the deepest along the path)
        "penetration_over_d": eq.penetration / (2.0 * scene.radius),
        "reaction_over_force_scale": eq.reaction, "coulomb_excess": eq.coulomb_excess,
        "contact_overlap_share": eq.overlap_share,
        # False: the final increment ended on its round budget, the lagged
        # friction not at its fixed point (another round would move the answer
        # by about last_round_move)
        "friction_settled": (None if failure is not None or eq.friction_settled is None
                             else bool(eq.friction_settled)),
        "last_round_move_over_r": (eq.last_round_move / scene.radius
                                   if failure is None and np.isfinite(eq.last_round_move)
                                   else None),
        # from the state two rounds before: small where the last round's move is
        # not, the rounds cycle between two states (null: not measured)
        "two_round_move_over_r": (eq.two_round_move / scene.radius
                                  if failure is None and np.isfinite(eq.two_round_move)
                                  else None),
        # passes of the final increment's rounds run for the friction to settle (--settle)
        "settle_passes": settle_passes(eq.increments),
        "dofs": info["free_dofs"], "iterations": eq.iterations,
        "increments": sum(inc.accepted for inc in eq.increments),
        "failed_increments": sum(not inc.accepted for inc in eq.increments),
        "elapsed_s": time.perf_counter() - t0,
        # summed over the increments: a resumed run's whole relaxation time
        "relax_s": float(sum(inc.seconds for inc in eq.increments)),
        "scene": scene.as_dict(), "start_gap_over_d": info["start_gap_over_d"],
        # the options relax_fabric was given (none: its defaults)
        "protocol": dict(relax_options or {}),
        "geometry_inflation": info["inflation"],
        # the pre-stretch the knit yarn still holds at the answer (or last equilibrium)
        "yarn_axial_strain": dict(zip(("median", "max"), yarn_axial_strain(model, eq.state))),
        "error": None if failure is None else str(failure),
        # the code that made it (a resumed run: the last process's; run.json has all)
        "source": source(),
    }
    if out is not None:
        _write_outputs(out, model, eq, summary, frames, render)
    return summary


def _write_outputs(out, model, eq, summary, frames, render):
    from ..io import write_beam_state, write_series
    name = f"curl_{summary['nw']}x{summary['nc']}"
    write_beam_state(out / f"{name}.vtu", model, eq.state)
    if frames:
        write_series(out / "path" / "path.pvd", [f for f, _ in frames],
                     frame_times([t for _, t in frames]))
    if render:
        from ..io import beam_mesh
        title = f"{summary['nw']} x {summary['nc']}: " + (
            f"{summary['curl']} curl" if summary["curl"] else
            f"NOT RELAXED, lam = {summary['last_equilibrium']['lam']:.3g}")
        render_views({view: out / f"{name}_{view}.png" for view in VIEWS},
                     beam_mesh(model, eq.state), min(r.section.radius for r in model.rods),
                     title)
    write_json(out / f"{name}.json", summary)


def frame_times(lams):
    """The path's times in path.pvd: homotopy lam, and 1 + k for the k-th
    settle pass at lam = 1 (ParaView lists one dataset per time)."""
    times, passes = [], 0
    for lam in lams:
        passes += bool(times) and lam == 1.0 and times[-1] >= 1.0
        times.append(lam + passes)
    return times


def render_views(paths, mesh, radius, title):
    """Tube renders of a swatch's line mesh (meshio), coloured by curvature:
    ``paths`` maps views of :data:`VIEWS` to PNG files; ``title`` gets the view."""
    from ..viz.render import render_rods
    for view, path in paths.items():
        render_rods(path, mesh, radius, scalars="curvature", view=VIEWS[view],
                    title=f"{title} ({view})",
                    camera_up=(0, 1, 0) if view == "front" else (0, 0, 1))

