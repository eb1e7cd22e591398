"""Files for a pop-up run: CSV, JSON, .vtu series, the Fig. 4a plot, a render.

Everything a reader of the paper would want to look at:
``branch.csv`` (the sampled stable path), ``branches.csv`` (every continuation
point of every branch with its stability), ``shapes/popup.pvd`` + one .vtu per
sample, ``popup_z.png`` (max|z|/L against c/L: planar, popped +/-, critical
point; Fig. 4a analogue) and ``popup_c0.60.png`` (off-screen tube render of the
popped rod seen along the course direction y; Fig. 4b analogue).
"""
from pathlib import Path

import numpy as np

from ..io import (beam_mesh, curve_mesh, save_figure, write_beam_state, write_csv, write_json,
                  write_mesh, write_series)
from .srod import max_abs_z


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def signed_height(state):
    """z of the node farthest from the plane, with its sign (mirror branches
    then plot as the two arms of the pitchfork)."""
    z = state.x[:, 2]
    return float(z[np.argmax(np.abs(z))])


def branch_rows(result):
    L = result.srod.length
    for name, branch in result.branches():
        for p in branch.points:
            yield {"branch": name, "c_over_L": p.lam, "z_over_L": signed_height(p.state) / L,
                   "max_abs_z_over_L": max_abs_z(p.state) / L, "negative_eigenvalues": p.negative,
                   "stable": bool(p.stable)}


def plot_height(result, path, marks=None, title=None):
    """max|z|/L (signed) vs c/L; stable solid, unstable dashed; critical point
    and the sampled path marked; ``marks``: extra c/L values to tick (e.g. the
    paper's grid)."""
    plt = _plt()
    L = result.srod.length
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    colours = {"planar": "C0", "popped (z > 0)": "C3", "popped (z < 0)": "C1"}
    for name, branch in result.branches():
        c = np.array([p.lam for p in branch.points])
        z = np.array([signed_height(p.state) / L for p in branch.points])
        stable = np.array([bool(p.stable) for p in branch.points])
        for mask, style in ((stable, "-"), (~stable, "--")):
            zz = np.where(mask, z, np.nan)
            if np.any(mask):
                ax.plot(c, zz, style, color=colours[name], lw=1.6,
                        label=f"{name} ({'stable' if style == '-' else 'unstable'})")
    s = result.samples
    ax.plot([x.c_over_L for x in s], [x.max_abs_z_over_L for x in s], "ko", ms=4,
            label="sampled stable path")
    if result.critical_c_over_L is not None:
        ax.axvline(result.critical_c_over_L, color="k", lw=0.8, ls=":")
        ax.annotate(f"$c_{{crit}}/L$ = {result.critical_c_over_L:.4f}",
                    (result.critical_c_over_L, 0), xytext=(8, 12), textcoords="offset points")
    if marks is not None:
        for m in marks:
            ax.axvline(m, color="0.85", lw=0.6, zorder=0)
    ax.invert_xaxis()
    ax.set_xlabel("c / L")
    ax.set_ylabel("z / L (node farthest from the plane)")
    ax.set_title(title or (f"S-rod pop-up, w/L = {result.srod.w / L:.3f}, "
                           f"GJ/EI = {result.srod.gj_ei:.3f}, {result.srod.elements} elements"))
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    save_figure(fig, path)
    return path


def _write_samples(samples, path):
    write_csv(path, ["c_over_L", "max_abs_z_over_L", "stable", "negative_eigenvalues"],
              [[f"{s.c_over_L:.6f}", f"{s.max_abs_z_over_L:.8f}", s.stable,
                getattr(s, "negative", "")] for s in samples])


def write_popup(result, out, *, render=True, marks=None, view_c=0.6):
    """Write the files listed in the module docstring into ``out``; returns the
    summary dict (also written as ``popup.json``)."""
    out = Path(out)
    (out / "shapes").mkdir(parents=True, exist_ok=True)
    summary = result.summary()
    _write_samples(result.samples, out / "branch.csv")
    rows = list(branch_rows(result))
    write_csv(out / "branches.csv", list(rows[0]), [list(r.values()) for r in rows])
    files = [write_beam_state(out / "shapes" / f"popup_c{s.c_over_L:.4f}.vtu", result.model,
                              s.state) for s in result.samples]
    write_series(out / "shapes" / "popup.pvd", files, [s.c_over_L for s in result.samples])
    plot_height(result, out / "popup_z.png", marks=marks)
    if render and result.popped:
        from ..viz.render import render_rods
        c = min(max(view_c, result.c_to), result.c_from)
        state = result.state_at(c)
        write_beam_state(out / f"popup_c{c:.2f}.vtu", result.model, state)
        render_rods(out / f"popup_c{c:.2f}.png", beam_mesh(result.model, state),
                    radius=0.5 * result.srod.diameter, view=(0.0, -1.0, 0.0), zoom=1.5,
                    title=f"c/L = {c:.2f}: popped S-rod seen along the course direction (y)")
    write_json(out / "popup.json", summary)
    return summary


def plot_heat_map(hm, path, title=None):
    """max|z|/L over (c/L, w/L) with the critical curve (paper Fig. 4c)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.8, 4.8))
    dc = abs(hm.c_over_L[0] - hm.c_over_L[1]) / 2
    dw = (hm.w_over_L[1] - hm.w_over_L[0]) / 2 if len(hm.w_over_L) > 1 else 0.01
    extent = [hm.c_over_L.min() - dc, hm.c_over_L.max() + dc,
              hm.w_over_L.min() - dw, hm.w_over_L.max() + dw]
    image = ax.imshow(hm.height[:, ::-1], origin="lower", aspect="auto", extent=extent,
                      cmap="magma")
    fig.colorbar(image, ax=ax, label="max |z| / L (stable path)")
    ax.plot(hm.critical, hm.w_over_L, "c-o", ms=3, lw=1.5, label="$c_{crit}/L$ (bifurcation)")
    unstable = ~hm.stable & np.isfinite(hm.height)
    if np.any(unstable):
        W, C = np.meshgrid(hm.w_over_L, hm.c_over_L, indexing="ij")
        ax.plot(C[unstable], W[unstable], "wx", ms=4, label="unstable sample")
    c = np.linspace(0.3, 1.0, 200)
    ax.plot(c, np.sqrt(np.clip(1 - c**2, 0, None)), "w--", lw=0.8, label="$w^2 + c^2 = L^2$")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.invert_xaxis()
    ax.set_xlabel("c / L")
    ax.set_ylabel("w / L")
    ax.set_title(title or "S-rod pop-up height over the loop shape (Fig. 4c analogue)")
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    save_figure(fig, path)
    return path


def yarn_mesh(model, q):
    """Centrelines of a B-spline yarn model as a line mesh (tangent, curvature)."""
    lines = model.centrelines(q)
    return curve_mesh([r for r, _, _ in lines], {"tangent": [t for _, t, _ in lines],
                                                 "curvature": [k for _, _, k in lines]})


def write_bspline_popup(result, out, *, render=True, marks=None, view_c=0.6):
    """The B-spline model's pop-up files: branch.csv, popup.json, shapes/*.vtu
    (+ .pvd), popup_z.png (samples and the critical bracket) and a render."""
    out = Path(out)
    (out / "shapes").mkdir(parents=True, exist_ok=True)
    summary = result.summary()
    _write_samples(result.samples, out / "branch.csv")
    files = [write_mesh(out / "shapes" / f"popup_c{s.c_over_L:.4f}.vtu", yarn_mesh(result.model,
                                                                               s.control))
             for s in result.samples]
    write_series(out / "shapes" / "popup.pvd", files, [s.c_over_L for s in result.samples])
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    c = [s.c_over_L for s in result.samples]
    ax.plot(c, [s.max_abs_z_over_L for s in result.samples], "ko-", ms=4,
            label=f"B-spline model, {result.segments} segments ({result.method} relaxation)")
    if result.critical_c_over_L is not None:
        ax.axvspan(*result.critical_bracket, color="C3", alpha=0.3)
        ax.axvline(result.critical_c_over_L, color="C3", lw=0.8, ls=":",
                   label=f"$c_{{crit}}/L$ = {result.critical_c_over_L:.4f}")
    for m in marks if marks is not None else []:
        ax.axvline(m, color="0.85", lw=0.6, zorder=0)
    ax.invert_xaxis()
    ax.set_xlabel("c / L")
    ax.set_ylabel("max |z| / L")
    ax.set_title(f"S-rod pop-up, yarn-level B-spline model, w/L = "
                 f"{result.srod.w / result.srod.length:.3f} (no twist energy)")
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    save_figure(fig, out / "popup_z.png")
    if render:
        near = min(result.samples, key=lambda s: abs(s.c_over_L - view_c))
        if near.max_abs_z_over_L > 0:
            from ..viz.render import render_rods
            render_rods(out / f"popup_c{near.c_over_L:.2f}.png",
                        yarn_mesh(result.model, near.control),
                        radius=0.5 * result.srod.diameter, view=(0.0, -1.0, 0.0), zoom=1.5,
                        title=f"c/L = {near.c_over_L:.2f}: B-spline yarn seen along y")
    write_json(out / "popup.json", summary)
    return summary
