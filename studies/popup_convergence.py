"""Studies (c) and (d): c_crit/L under mesh refinement (15, 30, 60, 120
elements) and for GJ/EI in {0.5, 2/3, 1} (for an isotropic circle nu = 1, 0.5, 0;
0.5 lies beyond isotropy, a yarn soft in torsion).

    python studies/popup_convergence.py --out studies/results/popup_convergence
"""
import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from knitfem.io import save_figure, write_json  # noqa: E402
from knitfem.scenes.popup_output import signed_height  # noqa: E402
from knitfem.scenes.srod import SRod, popup  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/popup_convergence")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    sizes = [15, 30, 60, 120]
    crit = [popup(SRod(elements=n)).critical_c_over_L for n in sizes]
    diffs = np.abs(np.diff(crit))
    extrapolated = crit[-1] + (crit[-1] - crit[-2]) / 3.0          # second order
    print("(c) c_crit/L vs elements")
    for n, c in zip(sizes, crit):
        print(f"  {n:4d}  {c:.8f}  error vs extrapolated {c - extrapolated:+.2e}")
    print(f"  successive differences {diffs}, ratios {diffs[:-1] / diffs[1:]}")

    torsion = {}
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for gj in (0.5, 2.0 / 3.0, 1.0):
        res = popup(SRod(gj_over_ei=gj))
        torsion[f"{gj:.4f}"] = res.critical_c_over_L
        for name, branch in res.branches():
            if name == "popped (z < 0)":
                continue
            ax[1].plot([p.lam for p in branch.points],
                       [abs(signed_height(p.state)) / res.srod.length for p in branch.points],
                       "-", color={0.5: "C0", 1.0: "C2"}.get(gj, "C1"),
                       label=f"GJ/EI = {gj:.3g}" if name == "planar" else None)
    print("(d) c_crit/L vs GJ/EI:", torsion)
    ax[0].semilogx(sizes, np.abs(np.array(crit) - extrapolated), "o-", label="|c_crit - extrap.|/L")
    ax[0].semilogx(sizes, 4e-3 * (np.array(sizes) / 15.0) ** -2, "k:", label="slope -2")
    ax[0].set_yscale("log")
    ax[0].set_xlabel("elements")
    ax[0].set_title(f"(c) convergence of c_crit/L (extrapolated {extrapolated:.6f})")
    ax[0].legend()
    ax[1].invert_xaxis()
    ax[1].set_xlabel("c / L")
    ax[1].set_ylabel("max |z| / L")
    ax[1].set_title("(d) pop-up for three torsional stiffnesses")
    ax[1].legend()
    fig.tight_layout()
    save_figure(fig, out / "popup_convergence.png")
    write_json(out / "popup_convergence.json", {
        "elements": sizes, "critical_c_over_L": crit, "successive_differences": diffs.tolist(),
        "difference_ratios": (diffs[:-1] / diffs[1:]).tolist(), "extrapolated": extrapolated,
        "critical_by_gj_over_ei": torsion})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
