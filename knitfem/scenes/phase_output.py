"""Outputs of the fabric phase sweep: ``phase.csv`` and the figures.

* :func:`write_phase_csv`: one row per point (:data:`~.curl_sweep.COLUMNS`);
* :func:`plot_phase_diagram`: the curl type over (N_w, N_c), the paper's
  Fig. 5d markers (circles side, diamonds double, triangles top/bottom;
  squares flat), filled only for converged relaxations; a point that did not
  converge is drawn hollow and grey in its last state's shape, a failed or
  unfinished one as a grey cross, with the experimental boundary
  N_w / N_c = 2 (side curl below it, paper Sec. 6);
* :func:`plot_phase_trends`: the centre height H (mm) and the relaxed loop
  aspect w/c against N_w / N_c (the paper's Fig. 2a / 2b analogues), same
  markers; failed points have no value and are only counted.
"""
import numpy as np

from ..io.atomic import save_figure, write_csv
from .curl_sweep import COLUMNS

MARKERS = {"side": "o", "double": "D", "top_bottom": "^", "flat": "s"}
COLOURS = {"side": "tab:blue", "double": "tab:purple", "top_bottom": "tab:red",
           "flat": "tab:green"}
NOT_CONVERGED = "0.45"            # grey edge of a hollow marker
BOUNDARY = 2.0                    # experimental N_w / N_c between side and other curls
PAPER_ROW = 20                    # the N_c of the paper's Fig. 2 (H and w/c against N_w/N_c)


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def write_phase_csv(rows, path):
    """Write the rows (dicts over COLUMNS; None as an empty cell) to ``path``."""
    def cell(v):
        return "" if v is None else v
    return write_csv(path, list(COLUMNS), [[cell(r.get(k)) for k in COLUMNS] for r in rows])


STATES = ("converged", "not converged", "failed", "not run")


def point_state(row):
    """"converged", "not converged" (a shape at the time or step limit),
    "failed" (no shape) or "not run" (the sweep has not reached it yet)."""
    if row.get("status") == "not run":
        return "not run"
    if row.get("status") != "done" or row.get("curl") is None:
        return "failed"
    return "converged" if row.get("converged") else "not converged"


def _groups(rows):
    """(label, state, curl, rows) for each marker group, legend order."""
    groups = []
    for state in ("converged", "not converged"):
        for curl in MARKERS:
            members = [r for r in rows if point_state(r) == state and r["curl"] == curl]
            if members:
                label = curl.replace("_", "/") + ("" if state == "converged"
                                                  else " (not converged)")
                groups.append((label, state, curl, members))
    for state, label in (("failed", "failed"), ("not run", "not run yet")):
        members = [r for r in rows if point_state(r) == state]
        if members:
            groups.append((label, state, None, members))
    return groups


def scatter_points(ax, rows, x, y, size=70):
    """Scatter rows on ``ax`` at (x(row), y(row)) with the curl markers:
    filled and coloured when converged, hollow and grey when not, grey
    crosses when failed, small grey dots where not run yet (skipped where
    y(row) is None).  Returns the
    collections by label."""
    drawn = {}
    for label, state, curl, members in _groups(rows):
        pts = [(x(r), y(r)) for r in members if y(r) is not None]
        if not pts:
            continue
        xs, ys = np.array(pts, float).T
        if state == "converged":
            style = dict(marker=MARKERS[curl], c=COLOURS[curl], edgecolors="k")
        elif state == "not converged":
            style = dict(marker=MARKERS[curl], facecolors="none", edgecolors=NOT_CONVERGED,
                         linestyle="--")
        elif state == "failed":
            style = dict(marker="x", c=NOT_CONVERGED)
        else:                       # not run yet: a dot where the grid goes on
            style = dict(marker=".", c="0.7")
        drawn[label] = ax.scatter(xs, ys, s=size, linewidths=1.3, label=label, zorder=3,
                                  **style)
    return drawn


def state_counts(rows):
    """How many rows are in each of :data:`STATES` (dict)."""
    states = [point_state(r) for r in rows]
    return {s: states.count(s) for s in STATES}


def counts_text(rows):
    """"3 converged, 1 failed": the non-zero :func:`state_counts`."""
    return ", ".join(f"{n} {s}" for s, n in state_counts(rows).items() if n)


def phase_diagram(rows, title=None):
    """The phase diagram figure (fig, ax) over N_w (x) and N_c (y)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8.6, 5.0))
    scatter_points(ax, rows, lambda r: r["nw"], lambda r: r["nc"], size=90)
    # points relaxed along several paths (--paths) that landed on more than one
    # curl: the marker is the chosen path's, the ring says it is not the only one
    several = [r for r in rows if "|" in str(r.get("curl_types") or "")]
    if several:
        ax.scatter([r["nw"] for r in several], [r["nc"] for r in several], s=260,
                   facecolors="none", edgecolors="tab:red", linewidths=1.4, zorder=2,
                   label="path dependent: other paths\ngave another curl (curl_types)")
    nc_max = max(r["nc"] for r in rows)
    nw_max = max(r["nw"] for r in rows)
    top = 1.1 * max(nc_max, nw_max / BOUNDARY)
    nc_line = np.array([0.0, top])
    ax.plot(BOUNDARY * nc_line, nc_line, "k--", lw=1.0,
            label=f"experiment: $N_w/N_c$ = {BOUNDARY:g}\n(side curl above-left)")
    ax.set_xlim(0, 1.08 * nw_max + 2)
    ax.set_ylim(0, 1.08 * nc_max + 2)
    ax.set_xlabel("$N_w$ (wales)")
    ax.set_ylabel("$N_c$ (courses)")
    ax.set_title(title or f"Curl phase diagram ({counts_text(rows)})", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0)
    fig.tight_layout()
    return fig, ax


def plot_phase_diagram(rows, path, title=None):
    """Write the phase diagram (see :func:`phase_diagram`) to ``path``."""
    fig, _ = phase_diagram(rows, title)
    return save_figure(fig, path)


def _row_line(ax, rows, value, nc):
    """The converged points of the course count ``nc`` joined in N_w/N_c order
    (the paper measured its trends along one such row; a shape out of time
    would draw a trend that is not there)."""
    held = sorted((r["nw"] / r["nc"], value(r)) for r in rows
                  if r["nc"] == nc and point_state(r) == "converged" and value(r) is not None
                  and np.isfinite(value(r)))
    if len(held) >= 2:
        x, y = zip(*held)
        ax.plot(x, y, color="0.35", lw=1.0, zorder=0,
                label=f"$N_c$ = {nc} (the paper's Fig. 2 row)")


def phase_trends(rows, knitted_aspect=None, row_nc=PAPER_ROW):
    """H and loop aspect w/c against N_w/N_c (fig, (ax_H, ax_aspect)); the
    points of the course count ``row_nc`` (the paper's 20) joined by a line."""
    plt = _plt()
    fig, (ax_h, ax_a) = plt.subplots(1, 2, figsize=(11.0, 5.2))
    ratio = lambda r: r["nw"] / r["nc"]                                  # noqa: E731
    height, aspect = (lambda r: r.get("height")), (lambda r: r.get("loop_aspect"))
    scatter_points(ax_h, rows, ratio, height)
    scatter_points(ax_a, rows, ratio, aspect)
    _row_line(ax_h, rows, height, row_nc)
    _row_line(ax_a, rows, aspect, row_nc)
    if knitted_aspect is not None:
        ax_a.axhline(knitted_aspect, color="0.3", lw=0.8, ls=":", label="knitted w/c")
    for ax in (ax_h, ax_a):
        ax.axvline(BOUNDARY, color="k", ls="--", lw=0.8,
                   label=f"experiment: boundary {BOUNDARY:g}")
        ax.set_xlabel("$N_w / N_c$")
        # under the panel: inside, it hid points of a grid that fills in over days
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3,
                  frameon=False)
    ax_h.set_ylabel("centre height H (mm, swatch laid knit face down)")
    ax_a.set_ylabel("relaxed loop aspect w/c (central loops)")
    ax_h.set_title("H vs $N_w/N_c$ (Fig. 2a analogue)", fontsize=10)
    ax_a.set_title("loop aspect vs $N_w/N_c$ (Fig. 2b analogue)", fontsize=10)
    fig.suptitle(f"{counts_text(rows)} (failed points have no H or w/c)", fontsize=9)
    fig.tight_layout()
    return fig, (ax_h, ax_a)


def plot_phase_trends(rows, path, knitted_aspect=None):
    """Write the H and loop-aspect figure (see :func:`phase_trends`) to ``path``."""
    fig, _ = phase_trends(rows, knitted_aspect)
    return save_figure(fig, path)
