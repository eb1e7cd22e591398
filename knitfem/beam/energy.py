"""A beam model's total potential at a fixed load factor, for energy minimisation.

The protocol of :mod:`knitfem.solve.minimize`: energy, gradient (= the
residual of :class:`knitfem.beam.static.StaticProblem` on the free dofs),
the exact symmetric Hessian and a positive semi-definite model of it built
from the PSD projections of every element, contact and friction block and
tie (:mod:`knitfem.solve.psd`).  Dead nodal forces and gravity enter the
potential as -lam f.(x - X); nodal moments about fixed axes have no potential
for large rotations and are refused.

``step_limit`` caps every step so that no node moves more than ``step`` (a
length, default half the smallest yarn radius) or turns more than ``turn``
radians: two yarns then approach by at most one radius per step, less than
the 2r + gap they would have to cross to tunnel through each other; the
line search rejects trial states that push yarns more than ``depth`` (4 % of
the smallest diameter) into each other (the depth guard of
:func:`knitfem.solve.minimize.minimize`), so no state on a relaxation's path
penetrates deeper (unless its start did).
"""
import numpy as np

from ..solve.psd import psd_project
from .assembly import DOFS_PER_NODE, block_matrix
from .element import ElementTurnError, element_forces


def symmetric_part(K):
    """The symmetric part of per-block matrices (m, w, w); factored blocks
    (:class:`knitfem.contact.friction.Factored`) are symmetric as they are."""
    return K if hasattr(K, "J") else 0.5 * (K + np.swapaxes(K, 1, 2))


class EnergyProblem:
    """Total potential of ``model`` at load factor ``lam`` on its free dofs."""

    def __init__(self, model, lam=1.0, *, step=None, turn=0.5, depth=0.04):
        for name, value in (("step", step), ("turn", turn), ("depth", depth)):
            if value is None and name == "step":      # None: half the smallest radius
                continue
            try:
                ok = not isinstance(value, bool) and np.isfinite(float(value)) and value > 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ValueError(f"EnergyProblem: {name} must be a positive finite number "
                                 f"(got {value!r})")
        model.check()
        f_ext = model.external_forces().reshape(-1, DOFS_PER_NODE)
        if np.any(f_ext[:, 3:] != 0):
            raise ValueError("energy minimisation needs conservative loads: nodal moments "
                             "about fixed axes have no potential (use forces or gravity)")
        self.model, self.lam = model, float(lam)
        self.f_ext = f_ext.ravel()
        self.X = model.assembly.initial_positions()
        self.free = ~model.fixed
        self.weight = model.residual_weights()[self.free]
        self.ref = model.force_scale(lam)
        radii = [r.section.radius for r in model.rods if np.isfinite(r.section.radius)]
        self.step = float(step) if step is not None else \
            0.5 * (min(radii) if radii else 0.05 * model.length_scale())
        self.turn = float(turn)
        # a fraction of the smallest yarn diameter: below the 5 % d a fabric
        # relaxation may reach on its way (issue 9)
        self.depth_limit = float(depth) * 2.0 * (min(radii) if radii else np.inf)
        self.refusal = None         # why the last refused trial state is outside the model

    def evaluate(self, state, hessian=True):
        """(E, g, H, H_psd): H CSR on the free dofs and H_psd a function returning
        its PSD model (built only when asked: the projections cost more than
        the rest of an iteration); both None without ``hessian``."""
        model, asm = self.model, self.model.assembly
        a, b = asm.elements
        try:
            energy, res, Ke = element_forces(state.x[a], state.x[b], state.q[a], state.q[b],
                                             asm.h, asm.gamma0, asm.kappa0, asm.CN, asm.CM,
                                             hessian)
        except ElementTurnError as err:
            # outside the model: a trial state the line search must refuse
            rod = model.rods[asm.rod_of_element[err.element]]
            first = int(np.flatnonzero(asm.rod_of_element == asm.rod_of_element[err.element])[0])
            self.refusal = (f"rod {rod.name or asm.rod_of_element[err.element]!r} element "
                            f"{err.element - first}: " + str(err).split(": ", 1)[1])
            return np.inf, np.full(int(self.free.sum()), np.nan), None, None
        E = float(energy.sum())
        f = np.bincount(asm.element_dofs.T.ravel(), weights=res.ravel(), minlength=asm.n_dofs)
        H = None
        blocks = []                 # (dofs, matrices) for the PSD model
        convex = []                 # (dofs, matrices) PSD by construction
        kept = {}                   # id(dofs) -> [dofs, summed dense blocks]
        if hessian:
            H = asm.scatter(symmetric_part(Ke), self.free)
        energies, groups = self.groups(state, hessian)
        for Ep in energies:
            E += Ep
        for _, dofs, fe, Kb, psd in groups:
            f += np.bincount(dofs.ravel(), np.ravel(fe), minlength=asm.n_dofs)
            if not (hessian and len(dofs)):
                continue
            if psd is False:
                H = H + block_matrix(dofs, symmetric_part(Kb), asm.n_dofs, self.free)
                blocks.append((dofs, Kb))
                continue
            # friction groups (psd True or None) keep their dofs for a round,
            # and the co-rotated friction's two groups share theirs: summed
            # first, they are scattered and symmetrised once
            dense = Kb.dense() if hasattr(Kb, "J") else Kb
            if id(dofs) in kept:
                kept[id(dofs)][1] = kept[id(dofs)][1] + dense
            else:
                kept[id(dofs)] = [dofs, dense]
            if psd:
                convex.append((dofs, Kb))
        for dofs, dense in kept.values():
            H = H + block_matrix(dofs, dense, asm.n_dofs, self.free, keep_pattern=True,
                                 symmetrize=True)
        u = state.x - self.X
        E -= self.lam * float(self.f_ext.reshape(-1, DOFS_PER_NODE)[:, :3].ravel() @ u.ravel())
        g = (f - self.lam * self.f_ext)[self.free]
        if not hessian:
            return E, g, None, None

        def psd_model():
            # groups PSD by construction (friction) enter as they are: their
            # projection was the largest cost of the model (25 x 35: 1.1 s of
            # 1.6 s for 7 521 30 x 30 friction blocks), for a round-off change
            Hp = asm.scatter(psd_project(Ke), self.free)
            for dofs, Kb in blocks:
                Hp = Hp + block_matrix(dofs, psd_project(Kb), asm.n_dofs, self.free)
            for dofs, Kb in convex:
                Hp = Hp + block_matrix(dofs, Kb, asm.n_dofs, self.free, keep_pattern=True)
            return Hp
        return E, g, H, psd_model

    def groups(self, state, hessian=True):
        """The terms besides the rods' elements, per block: (energies, [(name,
        dofs (m, w), gradients (m, w), Hessians or None, psd)]) with name
        "ties", "contact" or "friction" (psd as
        :meth:`knitfem.beam.yarn_contact.BeamContact.blocks` says: the
        co-rotated friction's geometric Hessian part comes as a second
        "friction" group with zero gradients)."""
        model = self.model
        energies, groups = [], []
        if model.tie_model is not None:
            Ep, fe, Kb = model.tie_model.element_forces(state.x, hessian)
            energies.append(float(Ep.sum()))
            groups.append(("ties", model.tie_model.dofs(), fe, Kb, False))
        if model.contact_model is not None:
            Ep, contact_groups = model.contact_model.blocks(state.x, state.q, hessian)
            energies.append(Ep)
            names = {False: "contact", True: "friction", None: "friction"}
            groups.extend((names[group[3]], *group) for group in contact_groups)
        return energies, groups

    def depth(self):
        """Deepest contact penetration (length, >= 0) of the last evaluated
        state; 0 without contact."""
        contact = self.model.contact_model
        report = contact.report if contact is not None else None
        return max(0.0, -report.min_gap) if report is not None else 0.0

    def residual(self, g):
        """Relative residual against the model's fixed force scale."""
        return float(np.linalg.norm(g * self.weight) / self.ref)

    def retract(self, state, dx):
        du = np.zeros(self.free.shape[0])
        du[self.free] = dx
        return self.model.retract(state, du)

    def step_limit(self, state, dx):
        du = np.zeros(self.free.shape[0])
        du[self.free] = dx
        du = du.reshape(-1, DOFS_PER_NODE)
        move = float(np.max(np.linalg.norm(du[:, :3], axis=1), initial=0.0))
        turn = float(np.max(np.linalg.norm(du[:, 3:], axis=1), initial=0.0))
        return min(1.0, self.step / max(move, 1e-300), self.turn / max(turn, 1e-300))
