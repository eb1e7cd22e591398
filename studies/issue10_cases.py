"""The tester's cases of issue 10 (1-3 and 6), one line each, so that the
outcome before and after the solver change can be compared with one command:

    python studies/issue10_cases.py                               # this checkout
    (output of this checkout: studies/results/stress/issue10_cases_after.txt)
    cd /tmp && PYTHONPATH=/tmp/before python /path/to/studies/issue10_cases.py

1  yarn_on_yarn(EI/r^3, factor) under loads 0.25..1 (factor 1e5 and 1e10):
   where the top yarn ends up, iterations, active pairs.
2  L/d = 1e4, 5000 elements, P L^2/EI = 10 in 10 steps: tip vs the elastica;
   end moment 2 pi EI/L at L/d = 1e4 x 2000 and 1e3 x 20000 elements in 10 steps.
3  L/d = 1e4, P L^2/EI = 1000 in one step, 64 elements: tip, stability flag and
   the lowest eigenvalues of the tangent; with require_stable where it exists.
6  a naturally curved (k0 = pi/L), unloaded rod held at its middle node only
   (free_body() where it exists, else a clamp there): convergence, reactions.
Only API that existed before issue 10 is needed; what is missing is reported.
"""
import time

import numpy as np

from knitfem import BeamModel, Rod, Section
from knitfem.solve.stability import lowest_eigenvalues
from knitfem.verify import cases, closed_form


def slender(Ld):
    d = 1.0 / Ld
    return Section.circle(d, E=64 / (np.pi * d**4), nu=0.5)


def report(name, fn):
    t = time.perf_counter()
    try:
        text = fn()
    except Exception as err:                     # the outcome is what we report
        text = f"{type(err).__name__}: {str(err)[:300]}"
    print(f"case {name}: {text} [{time.perf_counter() - t:.1f} s]", flush=True)


def case1(factor):
    q = 1e3 * np.pi / 64 / 0.5**3
    model = cases.yarn_on_yarn(q, factor=factor)
    nodes = model.assembly.node_offset
    steps = model.solve(loads=np.linspace(0.25, 1, 4))
    z = [float(s.state.x[nodes[1]:nodes[2], 2].max()) for s in steps]
    return (f"top yarn max z per step {np.array2string(np.array(z), precision=4)} (d = 1), "
            f"iterations {[s.iterations for s in steps]}, active pairs "
            f"{[s.report.active_pairs for s in steps]}")


def case2a():
    model = cases.cantilever_tip_load(5000, alpha=10.0, section=slender(1e4))
    steps = model.solve(loads=np.linspace(0.1, 1, 10))
    err = []
    for s in steps:
        x, y, _ = closed_form.elastica_tip_load(10.0 * s.load)
        err.append(max(abs(s.state.x[-1, 0] - x), abs(-s.state.x[-1, 1] - y)))
    return (f"tip error per step / L {np.array2string(np.array(err), precision=1)}, "
            f"iterations {[s.iterations for s in steps]}")


def case2b(Ld, n):
    model = cases.cantilever_end_moment(n, section=slender(Ld))
    steps = model.solve(loads=np.linspace(0.1, 1, 10))
    tip = np.linalg.norm(steps[-1].state.x[-1])
    return (f"L/d {Ld:g} x {n}: tip distance from the root {tip:.1e} L, iterations "
            f"{[s.iterations for s in steps]}")


def case3(require_stable):
    model = cases.cantilever_tip_load(64, alpha=1000.0, section=slender(1e4))
    options = {"require_stable": True} if require_stable else {}
    try:
        step = model.solve(loads=[1.0], **options)[-1]
    except TypeError as err:
        return f"not available ({err})"
    x, y, _ = closed_form.elastica_tip_load(1000.0)
    K = model.internal_forces(step.state, free=~model.fixed)[2]
    tip = step.state.x[-1]
    return (f"tip ({tip[0]:.5f}, {tip[1]:.5f}) vs elastica ({x:.5f}, {-y:.5f}), stable "
            f"{getattr(step, 'stable', 'n/a')}, negative eigenvalues "
            f"{getattr(step, 'negative_eigenvalues', 'n/a')}, lowest eigenvalues "
            f"{np.array2string(lowest_eigenvalues(K, 2), precision=4)}")


def case6():
    section = Section.circle(0.02, E=1e4, nu=0.5)
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 32, section,
                                     natural_curvature=(0.0, 0.0, np.pi)))
    if hasattr(model, "free_body"):
        how = "free_body()"
        model.free_body()
    else:
        how = "clamp at node 16 (no free_body)"
        model.clamp(rod, 16)
    step = model.solve(loads=[1.0])[-1]
    chord = np.linalg.norm(step.state.x[-1] - step.state.x[0])
    react = np.abs(model.reactions(step.state, 1.0)).max()
    return (f"{how}: converged, residual {step.history[-1]:.1e}, round-off limited "
            f"{step.roundoff_limited}, chord {chord:.10f} (2/pi = {2 / np.pi:.10f}), max "
            f"reaction {react:.1e}")


if __name__ == "__main__":
    for f in (1e5, 1e10):
        report(f"1 (factor {f:g})", lambda: case1(f))
    report("2a (elastica 1e4 x 5000)", case2a)
    report("2b (roll-up)", lambda: case2b(1e4, 2000))
    report("2b (roll-up)", lambda: case2b(1e3, 20000))
    report("3 (default)", lambda: case3(False))
    report("3 (require_stable)", lambda: case3(True))
    report("6 (free body)", case6)
