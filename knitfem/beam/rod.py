"""Rod geometry: nodes along the arclength, director frames, natural shape.

A :class:`Rod` holds two things that may differ:

* the *layout* (``X``, ``Q``): node positions (n+1, 3) and frames (n+1, 4) the
  rod starts from, e.g. a straight yarn or a planar elastica guess;
* the *natural* (stress-free) strains per element, ``gamma0`` and ``kappa0``
  (n, 3), measured in the material frame (d1 = tangent): a naturally straight
  rod has gamma0 = (1, 0, 0), kappa0 = 0; kappa0 = (twist, k2, k3) gives an
  intrinsically curved and twisted one.

``s`` (n+1,) is the reference arclength of the nodes; it is the coordinate of
the scikit-fem ``MeshLine`` the rod is assembled on.  Lengths in the model's
length unit (mm in the studies).
"""
from dataclasses import dataclass, field

import numpy as np

from .element import element_strains
from .rotation import director_frame, transported_frames
from .section import Section, check_positive


def _rows(name, value, width):
    """A finite (n, width) float array, or a ValueError naming ``name``."""
    a = np.asarray(value, dtype=float)
    if a.ndim != 2 or a.shape[1] != width:
        raise ValueError(f"{name} must have shape (n, {width}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite values (valid: finite numbers)")
    return a


def _vector3(name, value):
    a = np.asarray(value, dtype=float).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {np.shape(value)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return a


MAX_ELEMENTS = 10**7          # ~1 GB of nodes, frames and strains per rod
MAX_LENGTH = 1e100            # any unit: beyond it squared lengths overflow in double


def _elements(n):
    try:
        ok = not isinstance(n, (bool, str)) and int(n) == n and 1 <= int(n) <= MAX_ELEMENTS
    except (TypeError, ValueError, OverflowError):        # None, NaN, inf
        ok = False
    if not ok:
        # a float like 1.98e16 equals an integer: it tried to allocate petabytes
        raise ValueError(f"elements must be an integer in [1, {MAX_ELEMENTS}], got {n!r}")
    return int(n)


def node_tangents(points):
    """Unit tangents (n+1, 3) of a polyline: central chords inside, one-sided at ends."""
    t = np.empty_like(points)
    t[1:-1] = points[2:] - points[:-2]
    t[0] = points[1] - points[0]
    t[-1] = points[-1] - points[-2]
    return t / np.linalg.norm(t, axis=1, keepdims=True)


@dataclass
class Rod:
    """One rod: layout, natural strains and section (see module docstring)."""
    s: np.ndarray
    X: np.ndarray
    Q: np.ndarray
    section: Section
    gamma0: np.ndarray
    kappa0: np.ndarray
    name: str = field(default="rod")

    def __post_init__(self):
        if not isinstance(self.section, Section):
            raise ValueError("section must be a knitfem Section, got "
                             f"{type(self.section).__name__}")
        self.s = np.asarray(self.s, dtype=float)
        n = self.s.shape[0] - 1
        if self.s.ndim != 1 or n < 1:
            raise ValueError("s (node arclengths) must be a 1D array with at least 2 nodes")
        if not np.all(np.isfinite(self.s)) or np.any(np.diff(self.s) <= 0):
            raise ValueError("s (node arclengths) must be finite and strictly increasing")
        for name, shape in (("X", (n + 1, 3)), ("Q", (n + 1, 4)),
                            ("gamma0", (n, 3)), ("kappa0", (n, 3))):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape:
                raise ValueError(f"{name} must have shape {shape} for a rod with {n} "
                                 f"elements, got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} contains NaN or infinite values (valid: finite numbers)")
            setattr(self, name, a)
        norms = np.linalg.norm(self.Q, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-8):
            raise ValueError("Q (frames) must be unit quaternions")

    @property
    def n_elements(self):
        return self.s.shape[0] - 1

    @property
    def h(self):
        """Reference element lengths (n,)."""
        return np.diff(self.s)

    @property
    def length(self):
        return float(self.s[-1] - self.s[0])

    @classmethod
    def straight(cls, start, direction, length, elements, section, *, d3=None,
                 natural_curvature=None, name="rod"):
        """A straight layout from ``start`` along ``direction``.

        ``d3`` (default: z, or x for a rod along z) fixes the frame about the
        tangent; ``natural_curvature`` (3,) or (n, 3) = (twist, k2, k3) makes the
        stress-free shape curved while the rod starts straight.
        """
        n = _elements(elements)
        L = check_positive("length", length)
        start = _vector3("start", start)
        t = _vector3("direction", direction)
        if np.linalg.norm(t) == 0:
            raise ValueError("direction must be a non-zero vector")
        t = t / np.linalg.norm(t)
        if d3 is None:
            d3 = (1.0, 0.0, 0.0) if abs(t[2]) > 0.9 else (0.0, 0.0, 1.0)
        s = np.linspace(0.0, L, n + 1)
        X = start + s[:, None] * t
        Q = np.repeat(director_frame(t, _vector3("d3", d3)), n + 1, axis=0)
        gamma0 = np.tile([1.0, 0.0, 0.0], (n, 1))
        kappa0 = np.zeros((n, 3)) if natural_curvature is None else \
            np.broadcast_to(np.asarray(natural_curvature, float), (n, 3)).copy()
        return cls(s, X, Q, section, gamma0, kappa0, name)

    @classmethod
    def from_centerline(cls, points, section, *, s=None, tangents=None, d3=None,
                        natural="shape", name="rod"):
        """A rod through ``points`` (n+1, 3).

        s : node arclengths (default: cumulative chord length).
        tangents : node tangents (default: polyline chords).
        d3 : vector fixing the frames about the tangents; None = parallel
            transport (twist-free frames) from the first node.
        natural : "shape" - this curve is stress-free;  "straight" - the rod is
            naturally straight and starts bent into this curve.
        """
        X = _rows("points", points, 3)
        if X.shape[0] < 2:
            raise ValueError("points must hold at least 2 nodes")
        chords = np.linalg.norm(np.diff(X, axis=0), axis=1)
        if np.any(chords <= 0):
            raise ValueError("points must be distinct consecutive nodes (zero-length element)")
        if s is None:
            s = np.concatenate([[0.0], np.cumsum(chords)])
        t = node_tangents(X) if tangents is None else _rows("tangents", tangents, 3)
        t = t / np.linalg.norm(t, axis=1, keepdims=True)
        if d3 is None:
            hint = np.array([0.0, 0.0, 1.0]) if abs(t[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            Q = transported_frames(t, director_frame(t[0], hint)[0])
        else:
            Q = director_frame(t, _vector3("d3", d3))
        s = np.asarray(s, dtype=float)
        n = X.shape[0] - 1
        if natural == "shape":
            gamma0, kappa0, _ = element_strains(X[:-1], X[1:], Q[:-1], Q[1:], np.diff(s))
        elif natural == "straight":
            gamma0, kappa0 = np.tile([1.0, 0.0, 0.0], (n, 1)), np.zeros((n, 3))
        else:
            raise ValueError(f"natural must be 'shape' or 'straight', got {natural!r}")
        return cls(s, X, Q, section, gamma0, kappa0, name)

    @classmethod
    def arc(cls, radius, angle, elements, section, *, start=(0, 0, 0), tangent=(1, 0, 0),
            toward=(0, 1, 0), name="rod"):
        """A stress-free circular arc: starts at ``start`` along ``tangent`` and
        bends toward ``toward``; d3 is the arc's plane normal."""
        R = check_positive("radius", radius)
        phi_end = check_positive("angle", angle)
        # squared chord lengths must stay finite (norms of ~1e154 overflow)
        if R > MAX_LENGTH:
            raise ValueError(f"radius must be in (0, {MAX_LENGTH:g}], got {R:g}")
        n = _elements(elements)
        # each element turns by less than pi (the relative rotation's logarithm
        # is unique) and by enough to leave distinct nodes
        if not 1e-9 <= phi_end / n < np.pi:
            raise ValueError(f"angle / elements must be in [1e-09, pi) rad per element, got "
                             f"angle = {phi_end:g} over {n} elements")
        t0 = _vector3("tangent", tangent)
        t0 = t0 / np.linalg.norm(t0)
        n0 = _vector3("toward", toward)
        n0 = n0 - (n0 @ t0) * t0
        if np.linalg.norm(n0) < 1e-12:
            raise ValueError("toward must not be parallel to tangent")
        n0 = n0 / np.linalg.norm(n0)
        phi = np.linspace(0.0, phi_end, n + 1)[:, None]
        X = _vector3("start", start) + R * np.sin(phi) * t0 + R * (1 - np.cos(phi)) * n0
        tangents = np.cos(phi) * t0 + np.sin(phi) * n0
        return cls.from_centerline(X, section, s=R * phi[:, 0], tangents=tangents,
                                   d3=np.cross(t0, n0), name=name)
