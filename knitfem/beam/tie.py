"""Ties: stiff springs that keep two nodes at their initial distance.

A knitter weaves the yarn's tail into the edge: the tail is held there, not
clamped in space.  A tie models that between two nodes of (usually different)
rods, on their positions only (the frames stay free):

    W = k/2 (|x_a - x_b| - d0)^2,

with d0 the distance in the layout.  Forces and the exact tangent (its
transverse part k (1 - d0/d) (I - n n^T) is negative when the tie is
compressed) are added to the model's internal forces.  Units: k force/length.
"""
import numpy as np

from .assembly import DOFS_PER_NODE, block_matrix, block_vector


class Ties:
    """Springs between node pairs a[i], b[i] of rest length rest[i] and
    stiffness k[i]."""

    def __init__(self, a, b, rest, k):
        self.a, self.b = np.asarray(a, np.int64), np.asarray(b, np.int64)
        self.rest, self.k = np.asarray(rest, float), np.asarray(k, float)

    def __len__(self):
        return self.a.shape[0]

    def dofs(self):
        """(m, 6) translational dofs of (a, b) per tie."""
        nodes = np.stack([self.a, self.b], axis=1)
        return (DOFS_PER_NODE * nodes[:, :, None] + np.arange(3)).reshape(-1, 6)

    def element_forces(self, x, tangent=True):
        """Energies (m,), forces (m, 6) on (x_a, x_b) and tangents (m, 6, 6)."""
        u = x[self.a] - x[self.b]
        d = np.linalg.norm(u, axis=1)
        n = u / np.maximum(d, 1e-300)[:, None]
        stretch = d - self.rest
        energy = 0.5 * self.k * stretch**2
        g = (self.k * stretch)[:, None] * n
        forces = np.concatenate([g, -g], axis=1)
        if not tangent:
            return energy, forces, None
        nn = n[:, :, None] * n[:, None, :]
        K3 = self.k[:, None, None] * (nn + (stretch / np.maximum(d, 1e-300))[:, None, None]
                                      * (np.eye(3) - nn))
        K = np.concatenate([np.concatenate([K3, -K3], axis=2),
                            np.concatenate([-K3, K3], axis=2)], axis=1)
        return energy, forces, K

    def forces(self, x, n_dofs, tangent=True, free=None):
        """Energy, force vector (n_dofs,) and tangent (CSR, restricted to the
        ``free`` dofs if given)."""
        energy, fe, Ke = self.element_forces(x, tangent)
        dofs = self.dofs()
        K = block_matrix(dofs, Ke, n_dofs, free) if tangent else None
        return float(energy.sum()), block_vector(dofs, fe, n_dofs), K
