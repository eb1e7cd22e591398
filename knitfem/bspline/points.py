"""Points on the yarns: sampling matrices, dead loads and ties.

A point of yarn k at curve parameter t in [0, N_k] (N_k segments; segment
floor(t), u = t - floor(t)) is r = sum_j B_j(u) q_{s+j}: a linear map of the
control points, stored as a sparse matrix (3 m, 3 n).

* dead loads: a constant force F at a curve point, energy -F . r (a tip load);
* ties: two curve points (usually on different yarns) held at their initial
  distance L0 by a stiff spring, energy K/2 (|r_a - r_b| - L0)^2 - the yarn
  end woven into the bind-off, as a knitter darns a tail in.
Units: force, force per length (K), length.
"""
import numpy as np
from scipy import sparse

from .curve import basis
from .yarn import positive


def sampling_matrix(seg, B, n):
    """Sparse (3 S G, 3 n) map from control points to the points at the
    parameters whose basis values are B (G, 4) on every segment of ``seg`` (S, 4)."""
    S, G = seg.shape[0], B.shape[0]
    rows = np.arange(S * G)[:, None].repeat(4, axis=1)                   # (S G, 4)
    cols = np.repeat(seg, G, axis=0)                                     # (S G, 4)
    vals = np.tile(B, (S, 1))
    return _expand(rows.ravel(), cols.ravel(), vals.ravel(), S * G, n)


def _expand(rows, cols, vals, m, n):
    """Point-level sparse pattern (m, n) -> coordinate level (3m, 3n)."""
    k = np.arange(3)
    r = (3 * rows[:, None] + k).ravel()
    c = (3 * cols[:, None] + k).ravel()
    return sparse.csr_matrix((np.repeat(vals, 3), (r, c)), shape=(3 * m, 3 * n))


def locate(model, yarn, t):
    """Control-point indices (4,) and basis values (4,) of the point at curve
    parameter ``t`` of yarn ``yarn`` (ValueError outside [0, N])."""
    if not 0 <= int(yarn) < len(model.yarns) or int(yarn) != yarn:
        raise ValueError(f"yarn must be an integer in [0, {len(model.yarns) - 1}], got {yarn!r}")
    y = model.yarns[int(yarn)]
    t = float(t)
    if not (np.isfinite(t) and 0.0 <= t <= y.segments):
        raise ValueError(f"curve parameter t must be in [0, {y.segments}], got {t!r}")
    s = min(int(np.floor(t)), y.segments - 1)
    idx = (np.arange(s, s + 4) % y.control.shape[0]) + model.offset[int(yarn)]
    return idx, basis(np.array([t - s]))[0]


def point_matrix(model, located):
    """Sparse (3 m, 3 n) map to the m curve points ``located`` [(idx, B), ...]."""
    rows = np.repeat(np.arange(len(located)), 4)
    cols = np.concatenate([idx for idx, _ in located])
    vals = np.concatenate([B for _, B in located])
    return _expand(rows, cols, vals, len(located), model.n)


class DeadLoads:
    """Constant forces at curve points of a model."""

    def __init__(self, model):
        self.model = model
        self.items = []                 # (yarn, t, force (3,))

    def __bool__(self):
        return bool(self.items)

    def add(self, yarn, t, force):
        f = np.asarray(force, float)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise ValueError(f"force must be 3 finite numbers, got {force!r}")
        locate(self.model, yarn, t)
        self.items.append((int(yarn), float(t), f))

    def force(self):
        """Nodal forces (n, 3): each load spread over its 4 control points by B(u)."""
        out = np.zeros((self.model.n, 3))
        for yarn, t, f in self.items:
            idx, B = locate(self.model, yarn, t)
            np.add.at(out, idx, B[:, None] * f[None, :])
        return out


class Ties:
    """Springs holding pairs of curve points at their initial distance."""

    def __init__(self, model):
        self.model = model
        self.items = []                 # (yarn_a, t_a, yarn_b, t_b, stiffness)
        self._D = None
        self.length = np.zeros(0)

    def __bool__(self):
        return bool(self.items)

    def add(self, yarn_a, t_a, yarn_b, t_b, stiffness):
        """Tie the point t_a of yarn_a to t_b of yarn_b, stiffness K (force/length)."""
        K = positive("tie stiffness", stiffness)
        locate(self.model, yarn_a, t_a)
        locate(self.model, yarn_b, t_b)
        self.items.append((int(yarn_a), float(t_a), int(yarn_b), float(t_b), K))
        self._D = None

    def difference(self):
        """Sparse (3 m, 3 n) map q -> r_a - r_b of every tie; builds L0 on first use."""
        if self._D is None:
            m = self.model
            A = point_matrix(m, [locate(m, ya, ta) for ya, ta, _, _, _ in self.items])
            B = point_matrix(m, [locate(m, yb, tb) for _, _, yb, tb, _ in self.items])
            self._D = (A - B).tocsr()
            self.length = np.linalg.norm((self._D @ m._initial().ravel()).reshape(-1, 3), axis=1)
            self.stiffness = np.array([k for *_, k in self.items])
        return self._D

    def stretch(self, q):
        """Separation vectors (m, 3) and their change of length |d| - L0 (m,)."""
        d = (self.difference() @ np.asarray(q).ravel()).reshape(-1, 3)
        return d, np.linalg.norm(d, axis=1) - self.length

    def energy(self, q):
        """Energy and gradient (n, 3)."""
        d, ext = self.stretch(q)
        norm = np.maximum(np.linalg.norm(d, axis=1), 1e-300)
        f = (self.stiffness * ext / norm)[:, None] * d
        E = 0.5 * float(np.sum(self.stiffness * ext**2))
        return E, (self._D.T @ f.ravel()).reshape(-1, 3)

    def hessian(self, q, project=False):
        """Sparse Hessian (3n, 3n): K [n n^T + (1 - L0/|d|) (I - n n^T)] per tie."""
        d, ext = self.stretch(q)
        norm = np.maximum(np.linalg.norm(d, axis=1), 1e-300)
        n = d / norm[:, None]
        lateral = ext / norm
        if project:
            lateral = np.maximum(lateral, 0.0)
        nn = n[:, :, None] * n[:, None, :]
        blocks = self.stiffness[:, None, None] * (nn + lateral[:, None, None]
                                                  * (np.eye(3)[None] - nn))
        m = len(self.items)
        k = np.arange(3)
        rows = (3 * np.arange(m)[:, None, None] + k[None, :, None]).repeat(3, axis=2)
        cols = (3 * np.arange(m)[:, None, None] + k[None, None, :]).repeat(3, axis=1)
        Hd = sparse.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())),
                               shape=(3 * m, 3 * m))
        return self._D.T @ Hd @ self._D
