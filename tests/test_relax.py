"""Energy minimisation (knitfem.solve.minimize), PSD projection, ties, and the
fabric scene's building blocks (the full relaxation is in test_fabric.py)."""
import numpy as np
import pytest

from knitfem import BeamModel, Rod, Section
from knitfem.beam.energy import EnergyProblem
from knitfem.solve.minimize import RelaxationError, minimize
from knitfem.solve.psd import psd_project
from knitfem.verify import cases, closed_form


def test_psd_projection_clips_the_negative_eigenvalues_of_known_blocks(rng):
    """Blocks built as Q L Q^T from random orthogonal Q and chosen eigenvalues
    (half of them negative, spanning 1e-8...1e2 as a beam element's do) come
    back as Q max(L, 0) Q^T (1e-12 of the largest), PSD blocks unchanged, the
    non-symmetric part ignored."""
    Q = np.linalg.qr(rng.normal(size=(50, 12, 12)))[0]
    L = rng.choice([-1.0, 1.0], size=(50, 12)) * 10.0 ** rng.uniform(-8, 2, size=(50, 12))
    A = np.einsum("eij,ej,ekj->eik", Q, L, Q)
    reference = np.einsum("eij,ej,ekj->eik", Q, np.maximum(L, 0.0), Q)
    skew = rng.normal(size=A.shape)
    skew = skew - np.swapaxes(skew, 1, 2)
    assert np.abs(psd_project(A + skew) - reference).max() < 1e-12 * np.abs(L).max()
    S = np.einsum("eij,ej,ekj->eik", Q, np.abs(L), Q)
    assert np.abs(psd_project(S) - S).max() < 1e-12 * np.abs(L).max()
    assert psd_project(np.zeros((0, 12, 12))).shape == (0, 12, 12)


def test_minimisation_reaches_the_elastica_from_a_straight_rod():
    """Cantilever P L^2/EI = 10 minimised in one go from the straight rod (no
    load stepping): the tip within 4e-3 L of Bisshopp-Drucker's (64 elements of
    a rod with EA L^2/EI = 6400: extensible) and within 1e-8 L of Newton's
    load-stepped equilibrium of the same model; every accepted step lowered
    the energy."""
    section = Section.circle(0.05, E=1.0)
    model = cases.cantilever_tip_load(64, alpha=10.0, section=section)
    result = minimize(EnergyProblem(model, 1.0), model.initial_state(), tol=1e-10, max_iter=300)
    newton = model.solve(loads=np.linspace(0.1, 1.0, 10))[-1].state
    x, y, _ = closed_form.elastica_tip_load(10.0)
    tip = result.state.x[-1]
    assert abs(tip[0] - x) < 4e-3 and abs(tip[1] + y) < 4e-3
    assert np.abs(tip - newton.x[-1]).max() < 1e-8
    energies = [h[0] for h in result.history]
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(energies, energies[1:]))


def test_minimisation_refuses_moments_without_a_potential():
    model = cases.cantilever_end_moment(8)
    with pytest.raises(ValueError, match="conservative"):
        EnergyProblem(model, 1.0)


def test_minimisation_reports_a_gradient_that_is_not_the_energys():
    """A problem whose gradient is wrong cannot lower its energy along it:
    RelaxationError, keeping the state, instead of a false convergence."""
    class Wrong:
        def evaluate(self, x, hessian=True):
            E = float(x @ x)
            g = -2.0 * x                          # the wrong sign
            if not hessian:
                return E, g, None, None
            from scipy import sparse
            H = sparse.identity(x.size, format="csr")
            return E, g, H, lambda: H

        def residual(self, g):
            return float(np.linalg.norm(g))

        def retract(self, x, dx):
            return x + dx
    with pytest.raises(RelaxationError) as err:
        minimize(Wrong(), np.ones(3), tol=1e-12, max_iter=100)
    assert np.allclose(err.value.state, np.ones(3))


def test_an_indefinite_hessian_is_shifted_not_replaced_by_the_psd_model():
    """A chain of double wells, stiffly coupled, E = sum (x_i^2 - 1)^2 +
    5 (x_i - x_{i+1})^2, started near its saddle (the Hessian indefinite
    there, mildly against its diagonal, as a buckling swatch's), with a PSD
    model 1000 times too stiff: the minimiser shifts the exact Hessian until
    it is positive definite and reaches the minimum (every x_i = 1) in < 30
    steps; with that PSD model alone it creeps (each step g / 1000: the
    residual had not fallen after 60 steps)."""
    from scipy import sparse

    class Wells:
        def evaluate(self, x, hessian=True):
            d = np.diff(x)
            E = float(np.sum((x * x - 1.0) ** 2) + 5.0 * np.sum(d * d))
            g = 4.0 * x * (x * x - 1.0)
            g[:-1] -= 10.0 * d
            g[1:] += 10.0 * d
            if not hessian:
                return E, g, None, None
            n = x.size
            lap = sparse.diags([np.r_[1.0, 2.0 * np.ones(n - 2), 1.0], -np.ones(n - 1),
                                -np.ones(n - 1)], [0, 1, -1])
            H = sparse.csr_matrix(sparse.diags(12.0 * x * x - 4.0) + 10.0 * lap)
            return E, g, H, lambda: sparse.identity(n, format="csr") * 1e3

        def residual(self, g):
            return float(np.linalg.norm(g))

        def retract(self, x, dx):
            return x + dx
    x0 = 0.01 * (1.0 + 0.5 * np.cos(np.arange(8.0)))
    problem = Wells()
    assert np.linalg.eigvalsh(problem.evaluate(x0)[2].toarray()).min() < 0
    result = minimize(problem, x0, tol=1e-10, max_iter=30)
    assert result.converged and np.allclose(result.state, 1.0, atol=1e-9)
    assert all(h[4] == "exact" for h in result.history)
    # the shift it needs (~0.3 of the diagonal) is three decades above mu: with
    # one try of the exact Hessian (``shifts=1``) the first steps take the
    # PSD model instead, so the steps chose as the option says
    fewer = minimize(problem, x0, tol=1e-10, max_iter=30, raise_on_failure=False, shifts=1)
    assert fewer.history[0][4] == "psd"


class _Wall:
    """E = (x - target)^2 in 1D, a Hessian model ten times too soft (so the
    Newton step overshoots 10x and the line search cuts it), and a "contact"
    that x > 1 penetrates by x - 1 (depth_limit 0.5)."""
    depth_limit = 0.5

    def __init__(self, target):
        self.target, self.x = target, None

    def evaluate(self, x, hessian=True):
        from scipy import sparse
        self.x = x
        E, g = float((x[0] - self.target) ** 2), 2.0 * (x - self.target)
        H = sparse.csr_matrix([[0.2]])
        return (E, g, H, lambda: H) if hessian else (E, g, None, None)

    def depth(self):
        return max(0.0, float(self.x[0]) - 1.0)

    def residual(self, g):
        return float(np.linalg.norm(g))

    def retract(self, x, dx):
        return x + dx


def test_no_accepted_state_passes_the_depth_limit():
    """From x = 0 toward the minimum at 1.3 (depth 0.3, allowed) the first
    cut step that lowers the energy is x ~ 1.62 (depth 0.62 > 0.5: Armijo
    alone accepts it); the depth guard cuts it once more, and the minimiser
    still converges to the allowed minimum."""
    seen = []
    problem = _Wall(1.3)
    result = minimize(problem, np.zeros(1), tol=1e-6, max_iter=500,
                      progress=lambda it, E, res: seen.append(float(problem.x[0])))
    assert result.converged and abs(result.state[0] - 1.3) < 1e-6
    assert max(seen) <= 1.5 + 1e-12
    unguarded = _Wall(1.3)
    unguarded.depth = lambda: 0.0
    first = []
    minimize(unguarded, np.zeros(1), tol=1e-10, max_iter=3, raise_on_failure=False,
             progress=lambda it, E, res: first.append(float(unguarded.x[0])))
    assert first[0] > 1.6                          # what the guard prevents


def test_a_minimum_beyond_the_depth_limit_is_an_error_that_says_so():
    """The minimum at x = 3 lies 2 deep: the minimiser stops at the limit and
    says that the depth guard, not the energy, stopped it."""
    with pytest.raises(RelaxationError, match="deeper than 0.5 into each other") as err:
        minimize(_Wall(3.0), np.zeros(1), tol=1e-10, max_iter=500)
    assert err.value.state[0] <= 1.5 + 1e-12


def test_a_stall_after_an_earlier_depth_cut_is_not_blamed_on_the_guard():
    """The first line search is cut by the guard (x ~ 1.62 -> 0.81); beyond
    x = 0.7 the gradient has the wrong sign, so the minimiser then stalls for
    a reason that has nothing to do with depth: the message must not say it
    did (a counter over the whole run did)."""
    class WrongBeyond(_Wall):
        def evaluate(self, x, hessian=True):
            E, g, H, Hp = super().evaluate(x, hessian)
            return E, (-g if x[0] > 0.7 else g), H, Hp
    with pytest.raises(RelaxationError) as err:
        minimize(WrongBeyond(1.3), np.zeros(1), tol=1e-10, max_iter=500)
    assert "stalled" in str(err.value) and "deeper" not in str(err.value)


def test_tie_carries_the_load_as_springs_in_series():
    """Rod A (clamped at x = 0) and rod B (clamped at x = 2.1), A's end tied to
    B's start 0.1 away, a force P along +x at A's end: A's tip moves
    P / (EA/L + k EA/L / (k + EA/L)) (both rods axial springs EA/L, the tie
    k in series with B), to 1e-10."""
    section = Section(EA=100.0, GA2=50.0, GA3=50.0, GJ=1.0, EI2=1.0, EI3=1.0, radius=0.05)
    model = BeamModel()
    a = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, section))
    b = model.add_rod(Rod.straight((1.1, 0, 0), (1, 0, 0), 1.0, 4, section))
    k = 37.0
    model.tie(a, "end", b, "start", stiffness=k)
    model.clamp(a, "start")
    model.clamp(b, "end")
    P = 1e-3
    model.force(a, "end", (P, 0, 0))
    step = model.solve(loads=[1.0])[-1]
    EA_L = 100.0
    expected = P / (EA_L + k * EA_L / (k + EA_L))
    assert abs(step.state.x[model.node(a, "end"), 0] - 1.0 - expected) < 1e-10
    assert step.stable


def test_free_body_holds_one_node_and_its_reactions_vanish():
    """A naturally curved rod with no supports but free_body(): it relaxes to
    its natural shape, the held node's reaction is ~0 (1e-8 of the force scale)."""
    section = Section.circle(0.1, E=1.0)
    model = BeamModel()
    model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 16, section,
                               natural_curvature=(0.0, 0.0, 3.0)))
    node = model.free_body()
    step = model.solve(loads=[1.0])[-1]
    reaction = model.reactions(step.state, 1.0).reshape(-1, 6)[node]
    assert np.linalg.norm(reaction) < 1e-8 * model.force_scale()
    gamma, kappa, _ = model.assembly.strains(step.state.x, step.state.q)
    assert np.allclose(kappa[:, 2], 3.0, atol=1e-8)


@pytest.mark.parametrize("backend", ["qdldl", "cholmod"])
def test_sparse_cholesky_solves_and_refuses_what_is_not_positive_definite(rng, backend):
    """Both backends of the modified Newton step solve an SPD system to
    round-off (1e-12 relative residual) and raise NotPositiveDefinite for an
    indefinite or numerically singular one; an unknown backend is refused by
    name."""
    from scipy import sparse
    from knitfem.solve.factor import Cholesky, NotPositiveDefinite, cholmod_available
    if backend == "cholmod" and not cholmod_available():
        pytest.skip("scikit-sparse (the cholmod extra) is not installed")
    n = 300
    B = sparse.random(n, n, density=0.02, random_state=1, format="csc")
    A = sparse.csc_matrix(B @ B.T + sparse.identity(n))
    b = rng.normal(size=n)
    x = Cholesky(A, backend=backend).solve(b)
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b) * np.abs(A).sum(axis=1).max()
    with pytest.raises(NotPositiveDefinite):
        Cholesky(A - 2.0 * sparse.identity(n, format="csc") * abs(A).max(), backend=backend)
    # positive definite in exact arithmetic, but one pivot 1e-16 of the largest:
    # numerically singular (CHOLMOD's own test is only pivot <= 0), and a step
    # along that direction would be round-off amplified 1e16 times
    tiny = 1e-16 * abs(A).max()
    with pytest.raises(NotPositiveDefinite):
        Cholesky(sparse.block_diag([A, sparse.csc_matrix([[tiny]])], format="csc"),
                 backend=backend)
    with pytest.raises(ValueError, match="backend"):
        Cholesky(A, backend="umfpack")


@pytest.mark.parametrize("backend", ["qdldl", "cholmod"])
def test_factorizer_reuses_the_analysis_and_gives_the_same_factors(rng, backend):
    """Factorizer (the modified Newton steps' factorisations) analyses a
    pattern once and refactorises in place while it stays the same: its
    solves equal a fresh Cholesky's bit for bit for shifted matrices of one
    pattern, after a refused indefinite one, and after a change of pattern
    (a new analysis)."""
    from scipy import sparse
    from knitfem.solve.factor import Cholesky, Factorizer, NotPositiveDefinite, \
        cholmod_available
    if backend == "cholmod" and not cholmod_available():
        pytest.skip("scikit-sparse (the cholmod extra) is not installed")
    n = 300
    B = sparse.random(n, n, density=0.02, random_state=2, format="csc")
    A = sparse.csc_matrix(B @ B.T + 1e-3 * sparse.identity(n))
    C = sparse.csc_matrix(A + sparse.random(n, n, density=0.01, random_state=3).T @
                          sparse.random(n, n, density=0.01, random_state=3))   # another pattern
    b = rng.normal(size=n)
    factorize = Factorizer(backend=backend, reorder=0)
    for M in (A, A + 0.5 * sparse.identity(n), C, C + sparse.identity(n)):
        assert np.array_equal(factorize(M).solve(b), Cholesky(M, backend=backend).solve(b))
    with pytest.raises(NotPositiveDefinite):
        factorize(C - 2.0 * abs(C).max() * sparse.identity(n, format="csc"))
    M = C + 2.0 * sparse.identity(n)
    assert np.array_equal(factorize(M).solve(b), Cholesky(M, backend=backend).solve(b))
    assert factorize.factorizations == 6
    if backend == "cholmod":
        assert factorize.analyses == 2          # A's pattern, then C's
        assert factorize.orderings == 2


def test_factorizer_keeps_an_order_for_new_patterns_and_solves_to_round_off(rng):
    """A new pattern is factorised in the kept fill-reducing order (a natural
    analysis of the permuted matrix): solves agree with a fresh Cholesky's to
    round-off, shifted retries of one pattern reuse that analysis, a matrix
    that is not positive definite is still refused, and after ``reorder``
    new patterns the order is made afresh (then bit for bit again)."""
    from scipy import sparse
    from knitfem.solve.factor import Cholesky, Factorizer, NotPositiveDefinite, \
        cholmod_available
    if not cholmod_available():
        pytest.skip("scikit-sparse (the cholmod extra) is not installed")
    n = 300
    B = sparse.random(n, n, density=0.02, random_state=2, format="csc")
    base = sparse.csc_matrix(B @ B.T + 1e-3 * sparse.identity(n))
    extra = [sparse.random(n, n, density=0.002, random_state=10 + k) for k in range(3)]
    mats = [base] + [sparse.csc_matrix(base + E @ E.T) for E in extra]   # 4 patterns
    b = rng.normal(size=n)
    factorize = Factorizer(reorder=2, least_nnz=0)
    for k, M in enumerate(mats):
        for shift in (0.0, 0.5):
            S = sparse.csc_matrix(M + shift * sparse.identity(n))
            x, ref = factorize(S).solve(b), Cholesky(S).solve(b)
            if k in (0, 3):         # ordered afresh: the same factors
                assert np.array_equal(x, ref)
            else:                   # in the kept order
                assert not np.array_equal(x, ref)
                assert np.allclose(S @ x, b, rtol=0, atol=1e-10 * np.abs(b).max())
                assert np.abs(x - ref).max() <= 1e-8 * np.abs(ref).max()
        if k == 1:
            with pytest.raises(NotPositiveDefinite):
                factorize(sparse.csc_matrix(M - 2.0 * abs(M).max() * sparse.identity(n)))
    assert (factorize.factorizations, factorize.analyses, factorize.orderings) == (9, 4, 2)
    small = Factorizer(reorder=2, least_nnz=max(M.nnz for M in mats) + 1)   # all below: afresh
    for M in mats[:3]:
        assert np.array_equal(small(M).solve(b), Cholesky(M).solve(b))
    assert small.orderings == 3


def test_factorizer_orders_afresh_when_the_pattern_grew_beyond_its_share(rng):
    """The kept order is for patterns near the one it was made for: a matrix
    with more than ``growth`` more entries (the yarns coming into contact at
    a relaxation's start) is ordered afresh -- the same factors as a fresh
    Cholesky, bit for bit -- while one within it is factorised in the kept
    order (the 55 x 35's factor ran out of memory in the order of its
    contact-free start)."""
    from scipy import sparse
    from knitfem.solve.factor import Cholesky, Factorizer, cholmod_available
    if not cholmod_available():
        pytest.skip("scikit-sparse (the cholmod extra) is not installed")
    n = 600
    chain = sparse.diags([np.full(n - 1, -1.0), np.full(n, 4.0), np.full(n - 1, -1.0)],
                         [-1, 0, 1], format="csc")                 # yarns, no contact
    E = sparse.random(n, n, density=0.002, random_state=5)
    coupled = sparse.csc_matrix(chain + E @ E.T)                   # many new couplings
    i = np.arange(100)
    band = sparse.coo_matrix((np.full(100, 0.1), (i, i + 3)), shape=(n, n))
    near = sparse.csc_matrix(chain + band + band.T)                  # a few new couplings
    assert coupled.nnz > 1.05 * chain.nnz and chain.nnz < near.nnz <= 1.4 * chain.nnz
    b = rng.normal(size=n)
    factorize = Factorizer(reorder=10, least_nnz=0, growth=0.05)
    factorize(chain)
    x = factorize(coupled).solve(b)
    assert factorize.orderings == 2 and np.array_equal(x, Cholesky(coupled).solve(b))
    loose = Factorizer(reorder=10, least_nnz=0, growth=0.5)        # within its share: kept
    loose(chain)
    x = loose(near).solve(b)
    assert loose.orderings == 1 and loose.analyses == 2
    assert np.allclose(near @ x, b, rtol=0, atol=1e-10 * np.abs(b).max())


def test_kept_pattern_symmetrized_equals_the_blockwise_symmetric_part(rng):
    """block_matrix(..., keep_pattern=True, symmetrize=True) (the friction
    groups: one gather through the pattern's mirror) equals the symmetric
    part taken block by block and assembled, to round-off, on the free dofs;
    asked without a kept pattern it is refused."""
    from knitfem.beam.assembly import block_matrix, mirror_slots
    from knitfem.beam.energy import symmetric_part
    n_dofs = 40
    dofs = np.stack([rng.choice(n_dofs, 6, replace=False) for _ in range(25)])
    blocks = rng.normal(size=(25, 6, 6))
    free = np.ones(n_dofs, bool)
    free[[3, 17]] = False
    K = block_matrix(dofs, blocks, n_dofs, free, keep_pattern=True, symmetrize=True)
    R = block_matrix(dofs, symmetric_part(blocks), n_dofs, free)
    assert abs(K - R).max() <= 1e-14 * abs(R).max()
    assert abs(K - K.T).max() == 0.0
    indices, indptr = K.indices, K.indptr
    mirror = mirror_slots(indices, indptr, K.shape[0])
    rows = np.repeat(np.arange(K.shape[0]), np.diff(indptr))
    assert np.array_equal(indices[mirror], rows) and np.array_equal(rows[mirror], indices)
    with pytest.raises(ValueError, match="symmetrize needs keep_pattern"):
        block_matrix(dofs, blocks, n_dofs, free, symmetrize=True)


@pytest.mark.parametrize("option", [dict(depth=0.0), dict(depth=np.nan), dict(step=-1.0),
                                    dict(turn=np.inf), dict(turn=None), dict(depth="0.04"),
                                    dict(step=True)])
def test_energy_problem_refuses_a_nonpositive_or_nonfinite_limit(option):
    from knitfem.scenes.fabric import FabricScene, build
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    (name, _), = option.items()
    with pytest.raises(ValueError, match=f"{name} must be a positive finite number"):
        EnergyProblem(model, 1.0, **option)


def test_an_element_turned_by_half_a_turn_is_refused_by_name():
    """The element's triad mean is singular where its end frames differ by
    exactly pi (a ZeroDivisionError from deep in the kernel, seen on a 4 x 4
    swatch with GJ/EI = 1e-3): frames 179.9 deg apart are evaluated (they
    occur legitimately, see MAX_ELEMENT_TURN), a half turn raises an error
    naming the element, the energy problem turns it into an infinite energy
    (a trial the line search cuts) naming the rod and its element, and a
    minimiser that stalls on such trials says so."""
    from scipy.spatial.transform import Rotation
    from knitfem.beam.element import ElementTurnError, element_forces
    from knitfem.beam.rotation import quat_from_rotation
    model = BeamModel()
    section = Section.circle(0.05, E=1.0)
    model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, section, name="yarn"))
    model.clamp(0, 0)
    state = model.initial_state()
    turned = []
    for angle in (np.radians(179.9), np.pi):
        q = state.q.copy()
        twist = Rotation.from_rotvec([angle, 0.0, 0.0])
        q[3:] = quat_from_rotation(twist * Rotation.from_quat(q[3:], scalar_first=True))
        turned.append(type(state)(state.x, q))
    a, b = model.assembly.elements
    args = (model.assembly.h, model.assembly.gamma0, model.assembly.kappa0, model.assembly.CN,
            model.assembly.CM)
    E_ok = element_forces(turned[0].x[a], turned[0].x[b], turned[0].q[a], turned[0].q[b],
                          *args)[0]
    assert np.all(np.isfinite(E_ok))
    with pytest.raises(ElementTurnError, match="element 2: its end frames differ by half a turn"):
        element_forces(turned[1].x[a], turned[1].x[b], turned[1].q[a], turned[1].q[b], *args)
    problem = EnergyProblem(model, 1.0)
    E, g, H, _ = problem.evaluate(turned[1], True)
    assert E == np.inf and H is None
    assert problem.refusal.startswith("rod 'yarn' element 2: its end frames differ by half a turn")

    class Beyond(_Wall):
        refusal = "the reason"

        def evaluate(self, x, hessian=True):
            E, g, H, Hp = super().evaluate(x, hessian)
            return (np.inf if x[0] > 0.5 else E), g, H, Hp
    with pytest.raises(RelaxationError, match=r"left the model \(the reason\)"):
        minimize(Beyond(1.3), np.zeros(1), tol=1e-10, max_iter=500)


def test_a_stop_ends_the_minimisation_unconverged_where_it_was():
    """``stop(iteration, E, residual)`` is asked before every step, the start
    included; when it says so the minimisation returns the state it has
    reached, unconverged and ``stopped``, its history the steps taken."""
    from scipy import sparse

    class Quartic:
        def evaluate(self, x, hessian=True):
            E = float(np.sum(x ** 4) + np.sum(x ** 2))
            g = 4.0 * x ** 3 + 2.0 * x
            if not hessian:
                return E, g, None, None
            H = sparse.csr_matrix(sparse.diags(12.0 * x ** 2 + 2.0))
            return E, g, H, lambda: H

        def residual(self, g):
            return float(np.linalg.norm(g))

        def retract(self, x, dx):
            return x + dx
    asked = []

    def stop(it, E, res):
        asked.append(it)
        return it == 3
    result = minimize(Quartic(), np.full(4, 3.0), tol=1e-12, max_iter=50, stop=stop)
    assert result.stopped and not result.converged and result.iterations == 3
    assert asked == [0, 1, 2, 3] and len(result.history) == 3
    assert result.energy == Quartic().evaluate(result.state)[0] < Quartic().evaluate(
        np.full(4, 3.0))[0]
    whole = minimize(Quartic(), np.full(4, 3.0), tol=1e-12, max_iter=50)
    assert whole.converged and not whole.stopped and whole.iterations > 3


def test_a_full_steps_trial_brings_its_hessian_and_changes_no_bit():
    """After a full step the line search evaluates its first trial with the
    Hessian (mostly taken: the accepted state is not evaluated again).  That
    is only a saving if energy and gradient are the same bits with and without
    the Hessian: checked on a swatch with contact and friction at the states
    of the path, and the evaluations counted."""
    from knitfem.beam.energy import EnergyProblem
    from knitfem.scenes.fabric import FabricScene, Homotopy, build
    from knitfem.solve.minimize import minimize
    scene = FabricScene(3, 3, elements_per_loop=16, alpha=0.2)
    model, _, _ = build(scene)
    Homotopy.of_scene(model, scene).apply(0.3)
    state = model.initial_state()
    model.contact_model.anchor_friction(state.x, state.q)
    problem = EnergyProblem(model, 1.0)
    state = minimize(problem, state, tol=0.0, max_iter=20, raise_on_failure=False).state
    model.contact_model.anchor_friction(state.x, state.q)

    class Counted:
        def __init__(self, inner):
            self.inner, self.calls, self.states = inner, [], []

        def evaluate(self, x, hessian=True):
            self.calls.append(hessian)
            self.states.append(x)
            return self.inner.evaluate(x, hessian)

        def __getattr__(self, name):
            return getattr(self.inner, name)
    counted = Counted(problem)
    out = minimize(counted, state, tol=0.0, max_iter=25, raise_on_failure=False)
    assert model.contact_model.report.active_pairs > 0 and len(model.contact_model.anchors.key) > 0
    t = [h[3] for h in out.history]
    accepted = sum(1 for v in t if v > 0)
    saved = sum(1 for i in range(1, len(t)) if t[i - 1] == 1.0 and t[i] == 1.0)
    assert saved >= 10
    # the old line search evaluated every accepted state twice (trial, then with Hessian)
    again = sum(1 for a, b in zip(counted.states, counted.states[1:]) if a is b)
    assert again == accepted - saved
    for x in counted.states[::5]:
        E0, g0 = problem.evaluate(x, False)[:2]
        E1, g1 = problem.evaluate(x, True)[:2]
        assert E0 == E1 and np.array_equal(g0, g1)
