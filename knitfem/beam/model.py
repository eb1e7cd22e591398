"""A beam model: rods, supports, loads, and its equations at a load factor.

Scene set-up reads like the experiment::

    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), L, 16, section))
    model.clamp(rod, "start")
    model.moment(rod, "end", (0, 0, M))
    steps = model.solve(loads=np.linspace(0.1, 1, 10))

Degrees of freedom per node: ``ux uy uz`` (translation) and ``rx ry rz``
(spatial rotation increments about the global axes; rotations are stored as
quaternions and updated multiplicatively).  Loads and prescribed motions are
scaled by the load factor ``lam``: nodal forces, moments (fixed global
direction) and gravity by ``lam``, prescribed displacements and rotations by
the path functions the user gives (linear in ``lam`` by default).
"""
from dataclasses import dataclass

import numpy as np

from ..solve.stepping import load_stepping
from ..contact import DEFAULT_FACTOR, DEFAULT_REGULARISATION
from .assembly import DOFS_PER_NODE, RodAssembly
from .contact_options import ContactOptions
from .rod import Rod
from .yarn_contact import BeamContact, default_law
from .rotation import (quat_conjugate, quat_multiply, rotate_spatially, rotation_matrix,
                       rotation_vector)
from .supports import DOF_NAMES, Supports, _vector  # noqa: F401  (DOF_NAMES: part of the API)


@dataclass
class BeamState:
    """Configuration: positions x (n_nodes, 3), unit quaternions q (n_nodes, 4)."""
    x: np.ndarray
    q: np.ndarray

    def copy(self):
        return BeamState(self.x.copy(), self.q.copy())

    @property
    def frames(self):
        """Director frames (n_nodes, 3, 3); columns d1, d2, d3."""
        return rotation_matrix(self.q)


class BeamModel(Supports):
    """Rods with supports and loads; see the module docstring."""

    def __init__(self, rods=()):
        self.rods = []
        self._supports = {}       # global node -> _Support
        self._nodal = []          # (node, (6,) load at lam = 1)
        self._gravity = None
        self._plane = None
        self._assembly = None
        self._contact = None
        self._ties = []           # (node a, node b, stiffness or None)
        self._free_body = False   # held at one node by free_body()
        for r in rods:
            self.add_rod(r)

    # -- building the scene ----------------------------------------------------------
    def add_rod(self, rod):
        """Add a :class:`Rod`; returns its index."""
        if not isinstance(rod, Rod):
            raise ValueError(f"add_rod expects a knitfem Rod, got {type(rod).__name__}")
        if self._supports or self._nodal or self._ties:
            raise ValueError("add all rods before supports and loads (node numbering)")
        self.rods.append(rod)
        self._assembly = None
        return len(self.rods) - 1

    @property
    def assembly(self):
        if self._assembly is None:
            self._assembly = RodAssembly(self.rods)
        return self._assembly

    def node(self, rod, at):
        """Global node index of node ``at`` ('start', 'end' or an int) of rod ``rod``."""
        if not isinstance(rod, (int, np.integer)) or not 0 <= rod < len(self.rods):
            raise ValueError(f"rod must be an index in [0, {len(self.rods) - 1}], got {rod!r}")
        n = self.rods[rod].s.shape[0]
        if at == "start":
            i = 0
        elif at == "end":
            i = n - 1
        elif isinstance(at, (int, np.integer)) and -n <= at < n:
            i = int(at) % n
        else:
            raise ValueError(f"at must be 'start', 'end' or a node index in [-{n}, {n - 1}], "
                             f"got {at!r}")
        return int(self.assembly.node_offset[rod] + i)

    def contact(self, law=None, *, factor=DEFAULT_FACTOR, regularisation=DEFAULT_REGULARISATION,
                exclude=None, per_diameter=6, damping=0.0, duration=1.0, friction=0.0,
                slip=None, corotated=False):
        """Switch on penalty contact among all rods (self-contact included); the
        options are those of :class:`ContactOptions` (law, or factor and
        regularisation; exclude; per_diameter; damping and duration; friction
        and its stick slip, corotated friction planes)."""
        self._contact = ContactOptions(law, factor, regularisation, exclude, per_diameter,
                                       damping, duration, friction, slip, bool(corotated))
        self._contact_model = None

    @property
    def contact_model(self):
        """The :class:`BeamContact` (None without contact)."""
        if self._contact is None:
            return None
        if getattr(self, "_contact_model", None) is None:
            o = self._contact
            law = default_law(self.rods, o.factor, o.regularisation) if o.law is None else o.law
            self._contact_model = BeamContact(self.assembly, law, o.exclude, o.per_diameter,
                                              o.damping)
            self._contact_model.friction = o.friction
            self._contact_model.corotated = o.corotated
            radius = min(r.section.radius for r in self.rods)
            self._contact_model.slip = o.slip if o.slip is not None else 1e-3 * radius
        return self._contact_model

    @property
    def contact_duration(self):
        """Pseudo-time of the load path 0 -> 1 (for contact damping)."""
        return self._contact.duration if self._contact is not None else 1.0

    def contact_report(self, state):
        """Active pairs, min gap, max penetration, total normal force at ``state``."""
        if self.contact_model is None:
            return None
        self.contact_model.forces(state.x, tangent=False, q=state.q)
        return self.contact_model.report

    def tie(self, rod_a, at_a, rod_b, at_b, stiffness=None):
        """Keep node ``at_a`` of rod ``rod_a`` and node ``at_b`` of rod ``rod_b`` at
        their layout distance by a spring (a woven-in yarn tail; see
        :mod:`knitfem.beam.tie`).  stiffness : force/length, default EA/r of the
        softer rod (a piece of yarn one radius long).  Returns the tie's index."""
        a, b = self.node(rod_a, at_a), self.node(rod_b, at_b)
        if a == b:
            raise ValueError("tie: the two nodes must differ")
        if stiffness is not None:
            stiffness = float(stiffness)
            if not (np.isfinite(stiffness) and stiffness > 0):
                raise ValueError(f"tie stiffness must be finite and in (0, inf), got {stiffness!r}")
        self._ties.append((a, b, stiffness))
        self._tie_model = None
        return len(self._ties) - 1

    @property
    def tie_model(self):
        """The :class:`knitfem.beam.tie.Ties` of the model (None without ties)."""
        if not self._ties:
            return None
        if getattr(self, "_tie_model", None) is None:
            from .tie import Ties
            x = self.assembly.initial_positions()
            a, b, k = (np.array(v) for v in zip(*self._ties))
            rod_of_node = np.searchsorted(self.assembly.node_offset, np.arange(len(x)),
                                          side="right") - 1
            default = []
            for i, j in zip(a, b):
                rods = [self.rods[rod_of_node[i]], self.rods[rod_of_node[j]]]
                radius = min(r.section.radius for r in rods)
                EA = min(r.section.EA for r in rods)
                default.append(EA / radius if np.isfinite(radius) else EA / min(
                    r.h.min() for r in rods))
            k = np.where([v is None for v in k], default, [v or 0.0 for v in k]).astype(float)
            self._tie_model = Ties(a, b, np.linalg.norm(x[a] - x[b], axis=1), k)
        return self._tie_model

    def free_body(self, node=None):
        """Remove the six rigid motions of a free-floating scene by holding one
        node (position and frame; default the node nearest the centroid of the
        layout): a statically determinate support, so its reactions vanish at
        equilibrium (see :meth:`reactions`) and nothing else is constrained.
        Rods without supports of their own are then held by ties or contact.
        Returns the held node."""
        x = self.assembly.initial_positions()
        if node is None:
            node = int(np.argmin(np.linalg.norm(x - x.mean(axis=0), axis=1)))
        rod = int(np.searchsorted(self.assembly.node_offset, node, side="right") - 1)
        self.clamp(rod, int(node - self.assembly.node_offset[rod]))
        self._free_body = True
        return int(node)

    @property
    def free_floating(self):
        """Whether :meth:`free_body` holds this scene (its rigid motions are a
        near-zero mode about the held node, not a change of shape)."""
        return self._free_body

    def gravity(self, g):
        """Gravity acceleration (3,) acting on each rod's ``section.line_density``."""
        self._gravity = _vector("gravity", g)

    def restrict_to_plane(self):
        """Solve in the x-y plane only (uz, rx, ry eliminated): exact when the
        layout, its frames (one director along z) and all loads are planar."""
        x, q = self.assembly.initial_positions(), self.assembly.initial_rotations()
        if np.ptp(x[:, 2]) > 1e-12 * max(1.0, np.ptp(x)):
            raise ValueError("restrict_to_plane: the layout is not in a plane z = const")
        dz = np.abs(rotation_matrix(q)[:, 2, :])          # z-components of d1, d2, d3
        if np.any(np.abs(dz.max(axis=1) - 1.0) > 1e-9):
            raise ValueError("restrict_to_plane: every frame needs a director along z")
        self._plane = np.array([0, 0, 1, 1, 1, 0], bool)

    # -- the discrete equations ----------------------------------------------------------
    @property
    def fixed(self):
        """Boolean mask (n_dofs,) of supported dofs."""
        mask = np.zeros((self.assembly.n_nodes, DOFS_PER_NODE), bool)
        for node, sup in self._supports.items():
            mask[node] |= sup.mask
        if self._plane is not None:
            mask |= self._plane
        return mask.ravel()

    def external_forces(self):
        """Load vector (n_dofs,) at lam = 1 (nodal loads and gravity)."""
        asm = self.assembly
        f = np.zeros((asm.n_nodes, DOFS_PER_NODE))
        for node, load in self._nodal:
            f[node] += load
        f = f.ravel()
        if self._gravity is not None:
            rho = np.array([r.section.line_density for r in self.rods])
            f = f + asm.distributed_load(rho[:, None] * self._gravity)
        return f

    def check(self):
        """Raise ValueError for loads on supported dofs and unsupported rods."""
        fixed = self.fixed.reshape(-1, DOFS_PER_NODE)
        for node, load in self._nodal:
            hit = [DOF_NAMES[i] for i in np.flatnonzero((load != 0) & fixed[node])]
            if hit:
                raise ValueError(f"contradictory boundary conditions: a load acts on "
                                 f"supported dof(s) {hit} of node {node}; the support "
                                 "would absorb it")
        if self._contact is not None or self._free_body:
            return    # rods may be held by contact or ties; a singular tangent will tell
        for k, off in enumerate(self.assembly.node_offset[:-1]):
            end = self.assembly.node_offset[k + 1]
            if not fixed[off:end].any():
                raise ValueError(f"rod {k} has no support and would move as a rigid body; "
                                 "clamp, pin or prescribe at least one node (or call "
                                 "free_body() for a free-floating scene)")

    def initial_state(self):
        return BeamState(self.assembly.initial_positions(), self.assembly.initial_rotations())

    def apply_supports(self, state, lam):
        """Copy of ``state`` with supported nodes moved to their values at ``lam``."""
        s = state.copy()
        for node, sup in self._supports.items():
            target = np.asarray(sup.position(lam), dtype=float)
            s.x[node, sup.mask[:3]] = target[sup.mask[:3]]
            if sup.orientation is not None:
                qn = np.asarray(sup.orientation(lam), dtype=float)
                s.q[node] = qn if qn @ s.q[node] >= 0 else -qn
        return s

    def support_velocity(self, lam, step=1e-6):
        """d(prescribed dofs)/dlam (n_dofs,): translation rates and spatial
        angular velocities of the supports at lam (central differences of the
        user's path functions), zero elsewhere."""
        v = np.zeros((self.assembly.n_nodes, DOFS_PER_NODE))
        d = step * max(1.0, abs(lam))
        for node, sup in self._supports.items():
            if not sup.moving:
                continue
            rate = (np.asarray(sup.position(lam + d)) - np.asarray(sup.position(lam - d))) / (2 * d)
            v[node, :3] = np.where(sup.mask[:3], rate, 0.0)
            if sup.orientation is None or (sup.turn is not None and np.array_equal(
                    np.asarray(sup.turn(lam + d)), np.asarray(sup.turn(lam - d)))):
                continue                      # the frame does not turn with lam
            turn = quat_multiply(sup.orientation(lam + d), quat_conjugate(sup.orientation(lam - d)))
            v[node, 3:] = rotation_vector(turn)[0] / (2 * d)
        return v.ravel()

    def retract(self, state, du):
        """State reached by increments du (n_dofs,): x + u, q <- exp(theta) q."""
        du = du.reshape(-1, DOFS_PER_NODE)
        return BeamState(state.x + du[:, :3], rotate_spatially(state.q, du[:, 3:]))

    def extrapolate(self, previous, state, factor):
        """State reached by repeating the increment previous -> state ``factor`` times."""
        dq = quat_multiply(state.q, quat_conjugate(previous.q))        # spatial increment
        theta = rotation_vector(dq)
        return BeamState(state.x + factor * (state.x - previous.x),
                         rotate_spatially(state.q, factor * theta))

    def internal_forces(self, state, tangent=True, free=None, direction=None):
        """Energy, internal forces (n_dofs,) and tangent (CSR; restricted to the
        ``free`` dofs if that mask is given) of a state, contact included; with
        ``direction`` also K @ direction (all dofs) as a fourth value."""
        out = self.assembly.forces(state.x, state.q, tangent, free, direction)
        if self.tie_model is not None:
            Et, ft, Kt = self.tie_model.forces(state.x, self.assembly.n_dofs, tangent, free)
            out = (out[0] + Et, out[1] + ft, out[2] + Kt if tangent else None) + tuple(out[3:])
            if direction is not None:
                Ktd = self.tie_model.forces(state.x, self.assembly.n_dofs, True)[2]
                out = out[:3] + (out[3] + Ktd @ direction,)
        if self.contact_model is None:
            return out
        Ec, fc, Kc, Kvc = self.contact_model.forces(state.x, tangent, free, direction, state.q)
        energy, f, K = out[0] + Ec, out[1] + fc, (out[2] + Kc if tangent else None)
        if direction is None:
            return energy, f, K
        return energy, f, K, out[3] + Kvc

    def reactions(self, state, lam):
        """Support reactions (n_dofs,), zero on free dofs: f_int - lam f_ext."""
        _, f, _ = self.internal_forces(state, tangent=False)
        r = f - lam * self.external_forces()
        return np.where(self.fixed, r, 0.0)

    def length_scale(self):
        """Characteristic length of the scene (default: the longest rod; a scene
        of many loops sets a loop's length with :meth:`set_length_scale`): the
        unit of increments in convergence tests and of continuation steps, and
        the bending length of the stiffness force scale."""
        return self._length if getattr(self, "_length", None) else max(r.length for r in self.rods)

    def set_length_scale(self, length):
        """Use ``length`` (> 0) as the scene's characteristic length (see
        :meth:`length_scale`), e.g. the yarn length of one knitted loop."""
        v = float(length)
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"length scale must be finite and in (0, inf), got {length!r}")
        self._length = v

    def residual_weights(self):
        """(n_dofs,) weights of residual entries: 1 on forces, 1/h on moments with
        h the mean length of the node's elements, so that a moment imbalance
        counts like the force pair that would carry it across an element (a rod
        whose frames lag behind its positions is not taken for converged)."""
        asm = self.assembly
        a, b = asm.elements
        count = np.bincount(np.concatenate([a, b]), minlength=asm.n_nodes)
        h = (np.bincount(a, asm.h, asm.n_nodes) + np.bincount(b, asm.h, asm.n_nodes)) / \
            np.maximum(count, 1)
        h = np.where(count > 0, h, self.length_scale())
        return np.column_stack([np.ones((asm.n_nodes, 3)),
                                np.repeat(1.0 / h[:, None], 3, axis=1)]).ravel()

    def force_scale(self, lam=1.0):
        """A fixed force scale of the problem at load factor lam: the larger of
        the loads (weighted norm) and the bending force sqrt(n_nodes) EI/l^2 of
        the softest rod over the length scale l.  Relative residuals are taken
        against it, never against the current internal forces (which vanish for
        an unloaded free body and grow without bound at a diverged iterate)."""
        EI = min(min(r.section.EI2, r.section.EI3) for r in self.rods)
        stiffness = np.sqrt(self.assembly.n_nodes) * EI / self.length_scale() ** 2
        loads = np.linalg.norm(lam * self.external_forces() * self.residual_weights())
        return float(max(loads, stiffness))

    def position_scale(self):
        """Coordinates the model can reach: its layout's extent from the origin
        plus the longest rod (a fixed scale for the round-off of chords)."""
        x = self.assembly.initial_positions()
        return float(np.abs(x).max() + max(r.length for r in self.rods))

    def roundoff_floor(self):
        """Round-off level of the weighted residual norm, at the fixed
        :meth:`position_scale` (see RodAssembly.force_noise)."""
        return self.assembly.force_noise(self.position_scale())

    def static_problem(self, lam, relax_positions=True):
        """Newton problem (see :mod:`knitfem.solve.newton`) at load factor lam."""
        from .static import StaticProblem
        return StaticProblem(self, lam, relax_positions)

    def solve(self, loads=(1.0,), state=None, start=0.0, relax_positions=True,
              **newton_options):
        """Equilibria at the load factors ``loads``, stepping from ``state`` (default
        the layout) at load ``start``; failed steps are halved.  Returns a list of
        :class:`knitfem.solve.Step`, one per load (with contact, ``step.report`` is
        its :class:`knitfem.contact.ContactReport`).  ``relax_positions``: solve the
        positions exactly for the current frames after every update (see
        :meth:`StaticProblem.relax_positions`)."""
        self.check()
        state = self.initial_state() if state is None else state
        # contact makes the residual jump when yarns meet: a residual line search
        # keeps Newton from overshooting into (or through) the other yarn
        newton_options.setdefault("line_search", self._contact is not None)
        try:
            steps = load_stepping(lambda lam: self.static_problem(lam, relax_positions), state,
                                  list(loads), start=start, **newton_options)
        finally:
            if self.contact_model is not None:
                self.contact_model.rate_reference = None      # damping lives in increments only
        if self.contact_model is not None:
            for step in steps:
                step.report = self.contact_report(step.state)
        return steps
