"""One swatch relaxed along several homotopy schedules: the equilibria a
path-dependent knit lands on (``knitfem curl --paths default,coarse``).

A knit held by friction can have more than one curled equilibrium, and the
relaxation's path picks one: the 10 x 10 at alpha 0.2 and 32 elements per loop
relaxes to top/bottom curl with the default increments and to double curl with
increments of 0.3 (README, "two equilibria").  One run then cannot say which
curl the swatch has.  :func:`curl_paths` runs :func:`knitfem.scenes.curl.curl`
once per schedule and reports every answer, the set of curl types found and
which answer it takes as the swatch's (the lowest minimised potential among
the converged, stable ones: with friction a hint, not a proof, of the global
minimum; the potential includes the last friction round's, which is ~0 when
the friction settled).
"""
import json
import warnings
from pathlib import Path

from ..io.atomic import write_json
from ..io.run import source
from .fabric_relax import DLAM, DLAM_MAX

# homotopy increments: first step and largest step (relax_fabric's dlam, dlam_max)
SCHEDULES = {
    "default": {"dlam": DLAM, "dlam_max": DLAM_MAX},
    "coarse": {"dlam": 0.3, "dlam_max": 0.5},
    "fine": {"dlam": 0.05, "dlam_max": 0.1},
    # measured by studies/relax_protocol.py (its "thirds"): at (10, 35), alpha
    # 0.2, half the default's iterations for the same curl (README, "Bigger
    # increments with the depth guard")
    "thirds": {"dlam": 0.34, "dlam_max": 0.5},
}

# what each path's record keeps of its run's summary (the rest is in its folder)
KEPT = ("curl", "edges_touch", "roll_deg", "curvature_x", "curvature_y", "energy",
        "converged", "residual", "stable", "friction_settled", "settle_passes", "iterations",
        "relax_s", "error")


def parse_paths(text):
    """Schedule names from ``"default,coarse"``; None when ``text`` names an
    unknown schedule, none, or one twice (which would only rerun a path)."""
    names = [t.strip() for t in str(text).split(",") if t.strip()]
    ok = names and all(n in SCHEDULES for n in names) and len(set(names)) == len(names)
    return names if ok else None


def _answer(record):
    """A path that ended on a converged, stable, classified equilibrium."""
    return record["converged"] and record["stable"] and record["curl"] is not None


def choose(records):
    """Index of the answer taken as the swatch's: the lowest energy among the
    converged and stable paths, else None."""
    ok = [i for i, r in enumerate(records) if _answer(r) and r["energy"] is not None]
    return min(ok, key=lambda i: records[i]["energy"]) if ok else None


def combine(summaries, names):
    """The summary of several paths: the chosen path's own summary (or the
    first path's when none converged stably, its ``curl`` then None and its
    ``error`` saying why) with
    ``paths`` (one record per schedule), ``curl_types`` (the sorted set of
    the converged, stable paths' curls), ``path_dependent`` and
    ``chosen_path``."""
    records = [{"schedule": n, **SCHEDULES[n], **{k: s.get(k) for k in KEPT}}
               for n, s in zip(names, summaries)]
    chosen = choose(records)
    types = sorted({r["curl"] for r in records if _answer(r)})
    base = dict(summaries[chosen if chosen is not None else 0])
    if chosen is None:
        # the first path's shape is not an answer: say so (a caller that sees
        # "converged" alone would take it for one)
        base["curl"] = None
        base["error"] = base.get("error") or (
            f"no path ended on a converged, stable equilibrium (paths {', '.join(names)}: "
            + ", ".join(f"converged {r['converged']}, stable {r['stable']}" for r in records)
            + ")")
    base.update(paths=records, curl_types=types, path_dependent=len(types) > 1,
                chosen_path=names[chosen] if chosen is not None else None)
    return base


def settle_due(finished, settle, folder):
    """A finished run (its summary ``finished``, in ``folder``) whose friction
    did not settle goes on (resumed from its checkpoint) when ``settle`` asks
    for more settle passes than it has run; without its checkpoint it is kept
    as it is, with a warning (rerun from nothing it would not be the same path).
    One rule for ``--paths`` and the studies that resume finished runs."""
    from .fabric_rounds import settle_due_after
    due = settle_due_after(finished, settle)
    if due and not (folder / "checkpoint.npz").exists():
        warnings.warn(f"--settle: {folder} has no checkpoint to continue; its answer is kept "
                      "unsettled", stacklevel=3)
        return False
    return due


def curl_paths(scene, names, *, out=None, render=True, progress=True, resume=False,
               relax_options=None):
    """Relax ``scene`` along each schedule of ``names`` (keys of
    :data:`SCHEDULES`) and return :func:`combine`'s summary.  With ``out``
    each path writes into ``out/path_<name>/`` (its own checkpoint: ``resume``
    continues each; a path whose answer is already there is not rerun -- unless
    it failed, or settle passes are due (:func:`settle_due`) -- and one of
    another scene or protocol is refused like a checkpoint) and
    the combined summary goes to ``out/curl_<nw>x<nc>.json``."""
    from .curl import check_same_run, curl
    from .fabric import FabricScene
    out = Path(out) if out is not None else None
    summaries = []
    for name in names:
        folder = out / f"path_{name}" if out is not None else None
        done = folder / f"curl_{scene.nw}x{scene.nc}.json" if folder is not None else None
        options = {**SCHEDULES[name], **(relax_options or {})}
        if resume and done is not None and done.exists():
            # refused like a checkpoint when run otherwise (not mixed in)
            finished = json.loads(done.read_text())
            check_same_run(done, FabricScene.stored(finished.get("scene") or {}),
                           finished.get("protocol"), scene, options)
            # a failed path goes on from its checkpoint (a resume may have
            # raised its round budget: README, "A snap near lam 0.8")
            if finished.get("error") is None and not settle_due(finished, options.get("settle"), folder):
                summaries.append(finished)
                continue
        summaries.append(curl(scene, out=folder, render=render, progress=progress,
                              resume=resume, relax_options=options))
    summary = combine(summaries, names)
    summary["source"] = source()
    if out is not None:
        write_json(out / f"curl_{scene.nw}x{scene.nc}.json", summary)
    return summary
