"""The cases of the stress table (studies/stress.py): how each is built and
solved (worker side: only the knitfem API that also existed before issue 10, so
that an older checkout runs the same cases; verify.cases.crossed_beams is newer,
the crossed cases of a checkout without it count as n/a), what it measures, and what the
right answer is (parent side: closed forms, independent of the code under test).

Families (L = 1, EI = 1 unless stated; d the yarn diameter):

rollup     cantilever, end moment 2 pi EI/L: the tip returns to the root.  Exact
           at any mesh and any EA (no internal force): correct within 1e-6 L.
elastica   cantilever, dead tip load P L^2/EI = 10: reference the extensible,
           shearable elastica with the section's EA, GA (shooting, 1e-12);
           correct within 0.5 / n^2 + 1e-6 (L), 2.6x the discretisation error
           measured at 16 elements (0.19 / n^2).
parallel   yarn_on_yarn: a yarn lying on a clamped parallel one under a line load
           q = EI/r^3: the contact carries the weight (1e-4), the gap is uniform
           (1e-6 d) and the penetration below 1 % of d.
crossed    crossed clamped-clamped yarns, B's supports pushed down by 0.1 d: the
           contact force of linear beam theory with the penalty law integrated
           across the crossing (tests/test_contact.py), within 2.5 % (at push 0.1 d the
           test asks 1.5 %; at 0.025 d with the softest law the locally rigid
           crossing of the formula is off by 1.6 %).
column     clamped column (EI3 = 1, EI2 = 2, 128 elements) with a random imperfection
           in its first buckling mode (1 - cos 2 pi x)/2 plus a smaller one out of
           that plane, loaded to lam = P / P_cr: mid-span deflection of the
           imperfect elastica within 2 % (lam = lam_p(xi) xi / (xi + a0), lam_p the
           exact elastica, P_cr of the mesh 4 pi^2 (1 + (2 pi / n)^2 / 12)), on the
           branch the imperfection picks, and stable.
srod       the S-rod (paper Sec. 5) from c_crit + 0.02 down to just below or above
           the pop-up, with a random out-of-plane force at mid-length: popped on the
           imperfection's side with max|z| within 10 % of the perfect popped branch
           (reference: pseudo-arclength continuation of the perfect rod) below
           c_crit, planar (max|z| < 1e-3 L) above, and stable.

Every step a solve returns is checked (also the steps kept by an error), and
its stability flag, where the library gives one, against dense eigenvalues
of the tangent (problems up to 800 unknowns).
"""
from functools import lru_cache
import warnings

import numpy as np

DENSE_CHECK = 800           # dense eigenvalues of the tangent up to this many free dofs
R = 0.5                     # yarn radius of the contact families

# -- the grid ---------------------------------------------------------------------------


def grid(quick=False):
    """All cases (dicts of plain numbers), in the order they run."""
    rng = np.random.default_rng(20261210)
    out = []
    slender = [10.0, 1e2, 1e3, 1e4]
    elements = [16, 200, 2000, 20000]
    steps = [1, 10, 100]
    if quick:
        slender, elements, steps = [10.0, 1e4], [16, 200], [1, 10]
    for family in ("rollup", "elastica"):
        for Ld in slender:
            for n in elements:
                for k in steps:
                    if n * k > 200000:        # 20000 elements x 100 steps: 2-4 min each
                        continue
                    out.append(dict(family=family, Ld=Ld, n=n, steps=k))
    multipliers = [1e0, 1e4, 1e8] if quick else [10.0**e for e in range(9)]
    for family in ("parallel", "crossed"):
        for m in multipliers:
            for k in ([1, 4] if not quick else [4]):
                out.append(dict(family=family, multiplier=m, steps=k))
    for lam in ([0.99, 1.01] if quick else [0.9, 0.99, 1.01, 1.1]):
        for k in [1, 10]:
            for _ in range(1 if quick else 2):
                a0 = float(np.exp(rng.uniform(np.log(1e-5), np.log(1e-4))) * rng.choice([-1, 1]))
                az = float(0.1 * a0 * rng.uniform(-1, 1))
                for stable in (False, True):
                    out.append(dict(family="column", lam=lam, steps=k, a0=a0, az=az, n=128,
                                    require_stable=stable))
    for dc in ([-1e-3, 1e-3] if quick else [-1e-2, -1e-3, -1e-4, 1e-3]):
        for k in [1, 10]:
            for _ in range(1 if quick else 2):
                eps = float(np.exp(rng.uniform(np.log(1e-7), np.log(1e-4))) * rng.choice([-1, 1]))
                for stable in (False, True):
                    out.append(dict(family="srod", dc=dc, steps=k, eps=eps,
                                    require_stable=stable))
    for i, case in enumerate(out):
        case["id"] = i
    return out


def time_limit(case):
    """Seconds before a case counts as a hang (generous: the machine is shared)."""
    work = case.get("n", 64) * case["steps"]
    return 120.0 + 1e-3 * work

# -- worker side: build, solve, measure (knitfem API common to old and new code) --------


def slender_section(Ld):
    """Solid circle of diameter L/Ld with EI = 1 (L = 1)."""
    from knitfem import Section
    d = 1.0 / Ld
    return Section.circle(d, E=64.0 / (np.pi * d**4), nu=0.5)


COLUMN_EI = (2.0, 1.0)       # EI2 (deflection along z), EI3 (along y): the y mode buckles first


def imperfect_column(n, a0, az, force):
    from knitfem import BeamModel, Rod, Section
    k = 1e8
    section = Section(EA=k, GA2=k, GA3=k, GJ=1.0, EI2=COLUMN_EI[0], EI3=COLUMN_EI[1])
    x = np.linspace(0.0, 1.0, n + 1)
    phi = 0.5 * (1.0 - np.cos(2 * np.pi * x))
    points = np.column_stack([x, a0 * phi, az * phi])
    model = BeamModel()
    rod = model.add_rod(Rod.from_centerline(points, section, d3=(0, 0, 1), natural="shape"))
    model.clamp(rod, "start")
    model.fix(rod, "end", "uy uz rx ry rz")
    model.force(rod, "end", (-force, 0.0, 0.0))
    return model


def srod_loads(case, c_crit):
    """c/L of the steps of an S-rod case: from c_crit + 0.02 to c_crit + dc."""
    c_from, c = c_crit + 0.02, c_crit + case["dc"]
    return [round(float(v), 12) for v in c_from + (c - c_from) * np.arange(1, case["steps"] + 1)
            / case["steps"]]


def key(c):
    return f"{c:.10f}"


def build(case, refs):
    """(model, loads, start) of a case."""
    from knitfem.verify import cases
    f = case["family"]
    if f == "rollup":
        return cases.cantilever_end_moment(case["n"], section=slender_section(case["Ld"])), \
            None, 0.0
    if f == "elastica":
        return cases.cantilever_tip_load(case["n"], alpha=10.0,
                                         section=slender_section(case["Ld"])), None, 0.0
    if f == "parallel":
        EI = 1e3 * np.pi / 64
        return cases.yarn_on_yarn(EI / R**3, factor=100.0 * case["multiplier"]), None, 0.0
    if f == "crossed":
        return cases.crossed_beams(0.1, 100.0 * case["multiplier"]), None, 0.0
    if f == "column":
        force = case["lam"] * column_critical_load(case["n"])
        return imperfect_column(case["n"], case["a0"], case["az"], force), None, 0.0
    if f == "srod":
        from knitfem.scenes.srod import SRod
        srod = SRod()
        c_from = refs["srod"]["c_crit"] + 0.02
        model = srod.model(c_from)
        EI = srod.section.EI2
        model.force(0, srod.elements // 2, (0.0, 0.0, case["eps"] * EI / srod.length**2))
        return model, srod_loads(case, refs["srod"]["c_crit"]), c_from
    raise ValueError(f"unknown family {f!r}")


def measure(case, model, step):
    """What the classification needs from one returned step (plain numbers)."""
    f = case["family"]
    out = {"load": float(step.load), "iterations": int(step.iterations),
           "stable": getattr(step, "stable", None),
           "negative": getattr(step, "negative_eigenvalues", None)}
    x = step.state.x
    if f in ("rollup", "elastica"):
        out["tip"] = x[model.node(0, "end")].tolist()
    elif f == "parallel":
        nodes = model.assembly.node_offset
        _, fc, _, _ = model.contact_model.forces(x, tangent=False)
        top = slice(nodes[1], nodes[2])
        out.update(top_z=x[top, 2].tolist(), contact_on_top=float(-fc.reshape(-1, 6)[top, 2].sum()),
                   active=int(model.contact_report(step.state).active_pairs))
    elif f == "crossed":
        nodes = model.assembly.node_offset
        react = model.reactions(step.state, step.load).reshape(-1, 6)
        out.update(force=float(-react[nodes[1]:nodes[2], 2].sum()),
                   reaction_sum=float(np.abs(react[:, :3].sum(axis=0)).max()),
                   reaction_scale=float(np.abs(react[:, 2]).sum()),
                   active=int(model.contact_report(step.state).active_pairs))
    elif f == "column":
        mid = case["n"] // 2
        out["deflection"] = (x[mid, 1:] - model.rods[0].X[mid, 1:]).tolist()
    elif f == "srod":
        L = model.rods[0].length
        out.update(z_mid=float(x[x.shape[0] // 2, 2] / L), max_z=float(np.abs(x[:, 2]).max() / L))
    free = ~model.fixed
    if free.sum() <= DENSE_CHECK:
        K = model.internal_forces(step.state, free=free)[2]
        S = K.toarray()
        out["dense_negative"] = int(np.sum(np.linalg.eigvalsh(0.5 * (S + S.T)) < 0))
    return out

# -- parent side: references and the verdict on each step -------------------------------


def column_critical_load(n):
    """Critical load of the clamped column meshed with n elements (README: buckling
    error +(pi h / L_eff)^2 / 12, L_eff = L/2), for EI3 = 1."""
    return 4 * np.pi**2 * COLUMN_EI[1] * (1.0 + (2 * np.pi / n) ** 2 / 12.0)


def perfect_column_load(xi):
    """lam = P/P_cr on the perfect clamped elastica with mid-span deflection xi (L = 1):
    xi = k / K(k), lam = (2 K(k) / pi)^2 (m = k^2)."""
    from scipy.optimize import brentq
    from scipy.special import ellipk
    if xi == 0:
        return 1.0
    k = brentq(lambda k: k / ellipk(k * k) - xi, 1e-15, 0.8, xtol=1e-15)   # xi < 0.4
    return (2 * ellipk(k * k) / np.pi) ** 2


def column_deflection(lam, a0, natural=True):
    """|additional mid-span deflection| xi of the imperfect column at lam = P/P_cr
    (mesh): on the natural branch (the imperfection's side) lam = lam_p(xi) xi /
    (xi + |a0|) (linear theory: xi = |a0| lam / (1 - lam)); on the other side the
    stable, far solution of lam = lam_p(xi) xi / (xi - |a0|), None if there is none."""
    from scipy.optimize import brentq, minimize_scalar
    a = abs(a0)
    if natural:
        return brentq(lambda xi: perfect_column_load(xi) * xi / (xi + a) - lam, 0.0, 0.3,
                      xtol=1e-15, rtol=1e-13)
    g = lambda xi: perfect_column_load(xi) * xi / (xi - a) - lam          # noqa: E731
    turn = minimize_scalar(g, bounds=(a * (1 + 1e-9), 0.3), method="bounded",
                           options={"xatol": 1e-12}).x
    if g(turn) > 0:
        return None                   # below the limit point of the other branch
    return brentq(g, turn, 0.3, xtol=1e-15, rtol=1e-13)


def references(todo):
    """Reference data computed once in the parent (current knitfem)."""
    refs = {}
    if any(c["family"] == "srod" for c in todo):
        from knitfem.scenes.srod import SRod, max_abs_z, popup
        res = popup(SRod(), c_from=0.76, c_to=0.70, c_step=0.01)
        c_crit = float(res.critical_c_over_L)
        z = {}
        for case in todo:
            if case["family"] == "srod":
                for c in srod_loads(case, c_crit):
                    if c < c_crit and key(c) not in z:
                        z[key(c)] = max_abs_z(res.state_at(c)) / SRod().length
        refs["srod"] = {"c_crit": c_crit, "z": z}
    return refs


@lru_cache(maxsize=None)
def _elastica_tip(Ld, load):
    s = slender_section(Ld)
    from knitfem.verify.closed_form import extensible_elastica_tip
    return tuple(extensible_elastica_tip(10.0 * load, s.EA, s.GA2, s.EI3))


def elastica_reference(Ld, load):
    return np.array(_elastica_tip(Ld, round(load, 12)))


def verdict(case, m, refs):
    """(kind, detail) for one measured step; kind is 'correct', 'other branch' (an
    equilibrium of the right size on the side the imperfection does not pick:
    stable or not is judged by the caller) or 'wrong'."""
    f, lam = case["family"], m["load"]

    def ok(good, detail):
        return ("correct" if good else "wrong"), detail
    if f == "rollup":
        ref = np.array([np.sin(2 * np.pi * lam), 1 - np.cos(2 * np.pi * lam)]) / (2 * np.pi * lam)
        err = float(np.abs(np.array(m["tip"][:2]) - ref).max())
        return ok(err <= 1e-6, f"tip error {err:.2e} L (tol 1e-6)")
    if f == "elastica":
        tol = 0.5 / case["n"] ** 2 + 1e-6
        err = float(np.abs(np.array(m["tip"][:2]) - elastica_reference(case["Ld"], lam)).max())
        return ok(err <= tol, f"tip error {err:.2e} L (tol {tol:.1e})")
    if f == "parallel":
        d = 2 * R
        weight = lam * (1e3 * np.pi / 64) / R**3 * 9.5
        gap = np.array(m["top_z"]) - d
        load_err = abs(m["contact_on_top"] / weight - 1)
        good = m["active"] > 0 and load_err <= 1e-4 and np.ptp(gap) <= 1e-6 * d \
            and gap.min() >= -0.01 * d
        return ok(good, f"load carried {load_err:.1e} (tol 1e-4), gap {gap.mean():.3e} "
                        f"ptp {np.ptp(gap):.1e}, {m['active']} pairs")
    if f == "crossed":
        ref = crossed_reference(case["multiplier"], lam * 0.1)
        err = abs(m["force"] / ref - 1)
        balance = m["reaction_sum"] <= 1e-6 * max(m["reaction_scale"], 1e-300)
        return ok(err <= 0.025 and balance and m["active"] > 0,
                  f"force {m['force']:.4g} vs {ref:.4g} ({err:.1e}, tol 2.5e-2), balance {balance}")
    if f == "column":
        load = case["lam"] * lam
        y, z = m["deflection"]
        same_side = np.sign(y) == np.sign(case["a0"])
        xi_ref = column_deflection(load, case["a0"], natural=same_side)
        err = abs(abs(y) / xi_ref - 1) if xi_ref else np.inf
        # out of the buckling plane: below its own critical load (2x), amplified linearly
        z_ref = abs(case["az"]) * load / 2 / (1 - load / 2)
        good = err <= 0.02 and abs(z) <= 2 * z_ref + 1e-9
        detail = (f"deflection {y:.4e} vs {np.sign(y) * (xi_ref or np.nan):.4e} ({err:.1e}, "
                  f"tol 2e-2{'' if same_side else ', the other branch'}), out of plane "
                  f"{z:.1e} (<= {2 * z_ref:.1e})")
        return ("correct" if same_side else "other branch") if good else "wrong", detail
    if f == "srod":
        c_crit = refs["srod"]["c_crit"]
        if lam >= c_crit:
            return ok(m["max_z"] < 1e-3, f"planar above c_crit: max|z| {m['max_z']:.1e} L "
                                         "(tol 1e-3)")
        ref = refs["srod"]["z"][key(lam)]
        err = abs(m["max_z"] / ref - 1)
        side = np.sign(m["z_mid"]) == np.sign(case["eps"])
        detail = (f"c/L {lam:.6f}: max|z| {m['max_z']:.4e} vs {ref:.4e} ({err:.1e}, tol 0.1), "
                  f"z_mid {m['z_mid']:+.2e}, eps {case['eps']:+.1e}")
        return ("correct" if side else "other branch") if err <= 0.1 else "wrong", detail
    raise ValueError(f)


def crossed_reference(multiplier, push):
    """Contact force of tests/test_contact.py's formula for the crossed beams."""
    from scipy.integrate import quad
    from scipy.optimize import brentq
    from knitfem import Section
    from knitfem.contact import PenaltyLaw
    section = Section.circle(2 * R, E=1e4, nu=0.3)
    law = PenaltyLaw.relative(section.EI2, R, 100.0 * multiplier)
    L = 10.0

    def compliance(a):
        b = L - a
        return a**3 * b**3 / (3 * section.EI2 * L**3) + a * b / (section.GA2 * L)

    def force(h):
        reach = np.sqrt(max((2 * R + law.g0) ** 2 - h * h, 0.0))    # where the law acts
        with warnings.catch_warnings():        # 1e-12 asks for round-off at the stiffest law
            warnings.simplefilter("ignore")
            return 2 * quad(lambda s: law.force(np.hypot(s, h) - 2 * R) * h / np.hypot(s, h),
                            0, reach, epsabs=0, epsrel=1e-12, limit=400)[0]

    C = compliance(5.07) + compliance(5.05)
    h = brentq(lambda h: h - (2 * R + 0.06 - push + C * force(h)), 2 * R - 0.5 * R, 2 * R + 0.06,
               xtol=1e-15)
    return force(h)
