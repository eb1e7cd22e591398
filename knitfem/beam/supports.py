"""Supports and nodal loads of a :class:`knitfem.beam.model.BeamModel`.

Supports hold dofs where the layout puts them (clamp, pin, fix) or move them
with the load factor (prescribe); loads are dead nodal forces and moments about
fixed global axes, scaled by the load factor.  One support per dof: a second
support on a held dof is a contradiction and an error naming both.
"""
from dataclasses import dataclass

import numpy as np

from .rotation import quat_multiply, rotation_from_vector

DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


@dataclass
class _Support:
    kind: str
    mask: np.ndarray            # (6,) bool, fixed dofs of the node
    position: object            # lam -> (3,) target position (fixed components used)
    orientation: object         # lam -> (4,) target quaternion, or None
    turn: object = None         # lam -> (3,) the prescribed rotation vector, if any

    @property
    def moving(self):
        """Whether the support follows the load factor (a prescribed motion)."""
        return "prescribe" in self.kind


def _vector(name, value, size=3):
    a = np.asarray(value, dtype=float).reshape(-1)
    if a.shape != (size,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be {size} finite numbers, got {value!r}")
    return a


class Supports:
    """The support and load methods of a beam model (a mixin: the model owns
    ``node``, ``assembly``, ``_supports`` and ``_nodal``)."""

    def _layout(self, node):
        return self.assembly.initial_positions()[node], self.assembly.initial_rotations()[node]

    def _support(self, rod, at, kind, mask, position, orientation):
        node = self.node(rod, at)
        old = self._supports.get(node)
        if old is not None:
            if kind in ("clamp", "pin", "fix") and old.kind == kind and \
                    np.array_equal(old.mask, mask):
                return node                      # the same support twice
            clash = [DOF_NAMES[i] for i in np.flatnonzero(old.mask & mask)]
            if clash:
                raise ValueError(
                    f"contradictory boundary conditions at rod {rod} node {at!r}: "
                    f"'{kind}' on {clash} meets an existing '{old.kind}'; each degree of "
                    "freedom takes one support")
            # disjoint dofs: merge (a rotation target exists only with all of rx ry rz)
            old_position, translations = old.position, old.mask[:3]
            new_position = position
            position = lambda lam: np.where(translations, old_position(lam),  # noqa: E731
                                            new_position(lam))
            orientation = orientation if orientation is not None else old.orientation
            mask, kind = old.mask | mask, f"{old.kind}+{kind}"
        self._supports[node] = _Support(kind, mask, position, orientation)
        return node

    def clamp(self, rod, at):
        """Fix position and frame of a node where the layout puts them."""
        X, Q = self._layout(self.node(rod, at))
        return self._support(rod, at, "clamp", np.ones(6, bool), lambda lam: X,
                             lambda lam: Q)

    def pin(self, rod, at):
        """Fix the position of a node; its frame turns freely."""
        X, _ = self._layout(self.node(rod, at))
        return self._support(rod, at, "pin", np.array([1, 1, 1, 0, 0, 0], bool),
                             lambda lam: X, None)

    def fix(self, rod, at, dofs):
        """Fix selected dofs, e.g. ``"uz rx ry"``.  Fixed rotation components hold
        the spatial rotation increment at zero (exact when the node turns about
        one fixed axis, as in planar problems or a torqued clamped end)."""
        names = dofs.split() if isinstance(dofs, str) else list(dofs)
        bad = [d for d in names if d not in DOF_NAMES]
        if bad or not names:
            raise ValueError(f"dofs must be names from {DOF_NAMES}, got {dofs!r}")
        mask = np.array([d in names for d in DOF_NAMES])
        X, _ = self._layout(self.node(rod, at))
        return self._support(rod, at, "fix", mask, lambda lam: X, None)

    def prescribe(self, rod, at, *, displacement=None, rotation=None):
        """Move a node with the load factor.

        displacement : (3,) displacement at lam = 1 (applied as lam * value) or a
            callable lam -> (3,); fixes ux, uy, uz.
        rotation : (3,) rotation vector at lam = 1 (the node's frame becomes
            exp(lam * value) applied to its layout frame) or a callable
            lam -> (3,); fixes rx, ry, rz.
        """
        if displacement is None and rotation is None:
            raise ValueError("prescribe needs displacement and/or rotation")
        X, Q = self._layout(self.node(rod, at))
        mask = np.zeros(6, bool)
        position, orientation = (lambda lam: X), None
        if displacement is not None:
            disp = displacement if callable(displacement) else \
                (lambda lam, d=_vector("displacement", displacement): lam * d)
            position = lambda lam: X + _vector("displacement(lam)", disp(lam))  # noqa: E731
            mask[:3] = True
        if rotation is not None:
            rot = rotation if callable(rotation) else \
                (lambda lam, r=_vector("rotation", rotation): lam * r)
            orientation = lambda lam: quat_multiply(  # noqa: E731
                rotation_from_vector(_vector("rotation(lam)", rot(lam)))[0], Q)
            mask[3:] = True
        node = self._support(rod, at, "prescribe", mask, position, orientation)
        self._supports[node].turn = rot if rotation is not None else None
        return node

    def force(self, rod, at, F):
        """Dead nodal force (3,) at lam = 1."""
        self._nodal.append((self.node(rod, at), np.r_[_vector("force", F), np.zeros(3)]))

    def moment(self, rod, at, M):
        """Nodal moment (3,) about fixed global axes at lam = 1."""
        self._nodal.append((self.node(rod, at), np.r_[np.zeros(3), _vector("moment", M)]))
