"""A beam model's equilibrium at a fixed load factor, as a Newton problem."""
import numpy as np

from ..solve.newton import linear_solve


class StaticProblem:
    """The model's equilibrium at fixed lam, on the free dofs, for Newton.

    Its norm weighs moments by 1/h (the node's element length) so a moment
    imbalance counts like the force pair carrying it; the relative residual is
    |r| over the model's fixed force scale (loads, or the bending force of its
    softest rod), its round-off floor is taken at the model's fixed position
    scale, and increments are measured against its length scale (translations)
    and in radians (rotations): see :mod:`knitfem.solve.newton`.
    """

    def __init__(self, model, lam, relax_positions=True):
        self.model = model
        self.lam = float(lam)
        self.free = ~model.fixed
        self.relax = relax_positions
        rotational = np.tile([False, False, False, True, True, True], model.assembly.n_nodes)
        self.translations = self.free & ~rotational
        self.weight = model.residual_weights()
        self.f_ext = model.external_forces()
        self.ref = model.force_scale(self.lam)
        self.floor = model.roundoff_floor()
        self.size = model.position_scale()
        self.step_unit = np.where(rotational, 1.0, 1.0 / model.length_scale())[self.free]

    def begin_increment(self, lam_prev, state_prev):
        """The increment from (lam_prev, state_prev) to lam: the reference of
        contact damping (gap rates over the pseudo-time of the increment)."""
        contact = self.model.contact_model
        if contact is None or contact.damping == 0.0:
            return
        dt = abs(self.lam - lam_prev) * self.model.contact_duration
        contact.rate_reference = (state_prev.x.copy(), dt) if dt > 0 else None

    def start(self, state):
        return self.relax_positions(self.model.apply_supports(state, self.lam))

    def relax_positions(self, state):
        """Positions in equilibrium for the current frames: with the frames fixed
        the energy is quadratic in the positions, so one linear solve of the
        translational block gives them exactly.  Stiff axial and shear strains
        then never dominate the residual, and Newton is left with the soft
        bending and twisting problem (3 iterations instead of 8-12 per load
        step for slender rods).  Near a solution this keeps Newton quadratic."""
        if not self.relax or not np.any(self.translations):
            return state
        _, f, K = self.model.internal_forces(state, True, self.translations)
        r = (f - self.lam * self.f_ext)[self.translations]
        du = np.zeros(self.free.shape[0])
        try:
            du[self.translations] = -linear_solve(K, r)
        except (RuntimeError, np.linalg.LinAlgError):
            return state          # singular translational block: let Newton report it
        return self.model.retract(state, du)

    def norm(self, r_free):
        return float(np.linalg.norm(r_free * self.weight[self.free]))

    def noise(self, state):
        """Round-off level of |r| at the model's fixed position scale (see
        RodAssembly.force_noise): stiff, finely meshed rods under small loads
        cannot get below it.  Contact adds its own, for the pairs now active."""
        if self.model.contact_model is None:
            return self.floor
        return float(np.hypot(self.floor, self.model.contact_model.noise(self.size)))

    def correction_norm(self, du_free):
        """Largest increment: translations over the length scale, rotations in rad."""
        return float(np.max(np.abs(du_free * self.step_unit), initial=0.0))

    def evaluate(self, state, jacobian=True):
        _, f, J = self.model.internal_forces(state, jacobian, self.free)
        r = f - self.lam * self.f_ext
        return r[self.free], J, self.ref

    def retract(self, state, du_free):
        du = np.zeros(self.free.shape[0])
        du[self.free] = du_free
        return self.relax_positions(self.model.retract(state, du))

    def extrapolate(self, previous, state, factor):
        """Secant predictor: repeat the last increment (positions linearly,
        rotations along their geodesics) ``factor`` times."""
        return self.model.extrapolate(previous, state, factor)
