"""A beam model as a parametrised system R(u, lam) = 0 for continuation.

The parameter lam drives the loads (``lam * f_ext``) and the prescribed
motions (the path functions given to ``BeamModel.prescribe``).  Unknowns are
the increments of the free dofs; every state handed out satisfies the
supports at its own lam.  dR/dlam is the tangent times the supports'
velocity minus the load vector; the velocity is a central difference of the
user's path functions (step 1e-6 max(1, |lam|): exact for the linear paths
of the scenes, second order otherwise), not an exact derivative.
"""
import numpy as np

from .assembly import DOFS_PER_NODE


class ParametricProblem:
    """R(u, lam) on the free dofs of ``model``, in the protocol of
    :mod:`knitfem.solve.continuation`.

    ``weights`` make the arclength an RMS over nodes: translations divided by
    the model length scale, rotations in radians, both by sqrt(n_nodes), so a
    step ds means about the same motion whatever the mesh.
    """

    def __init__(self, model):
        model.check()
        self.model = model
        self.free = ~model.fixed
        n_nodes = model.assembly.n_nodes
        rotational = np.tile([False] * 3 + [True] * 3, n_nodes)
        self.scale = model.residual_weights()
        unit = np.where(rotational, 1.0, 1.0 / model.length_scale())
        self.weights = (unit / np.sqrt(n_nodes))[self.free]
        self.step_unit = unit[self.free]
        self.f_ext = model.external_forces()
        self.floor = model.roundoff_floor()
        self.size = model.position_scale()
        self._loads = float(np.linalg.norm(self.f_ext * self.scale))
        self._stiffness = model.force_scale(0.0)
        # one rod numbered along its length has a banded Jacobian: keep that order
        self.ordering = "NATURAL" if len(model.rods) == 1 else "COLAMD"

    def state_at(self, state, lam):
        """``state`` with its supported nodes moved to their values at lam."""
        return self.model.apply_supports(state, lam)

    def evaluate(self, state, lam, jacobian=True):
        if jacobian:
            _, f, J, Kv = self.model.internal_forces(state, True, self.free,
                                                     self.model.support_velocity(lam))
        else:
            _, f, J = self.model.internal_forces(state, False)
        R = f - lam * self.f_ext
        ref = max(abs(lam) * self._loads, self._stiffness)      # model.force_scale(lam)
        if not jacobian:
            return R[self.free], None, None, ref
        return R[self.free], J, (Kv - self.f_ext)[self.free], ref

    def retract(self, state, du_free, lam):
        du = np.zeros(self.free.shape[0])
        du[self.free] = du_free
        return self.model.apply_supports(self.model.retract(state, du), lam)

    def norm(self, r_free):
        return float(np.linalg.norm(r_free * self.scale[self.free]))

    def noise(self, state):
        """Round-off floor at the model's fixed position scale (see StaticProblem)."""
        if self.model.contact_model is None:
            return self.floor
        return float(np.hypot(self.floor, self.model.contact_model.noise(self.size)))

    def correction_norm(self, du_free):
        """Largest increment: translations over the length scale, rotations in rad."""
        return float(np.max(np.abs(du_free * self.step_unit), initial=0.0))

    def full(self, v_free):
        """A free-dof vector (e.g. a null vector) as (n_nodes, 6)."""
        v = np.zeros(self.free.shape[0])
        v[self.free] = v_free
        return v.reshape(-1, DOFS_PER_NODE)
