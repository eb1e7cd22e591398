"""A plain-knit swatch as a B-spline yarn model (the paper's own model, Sec. 6).

Scene input is shared with the beam path (:func:`knitfem.geometry.swatch.plain_knit_swatch`,
:func:`~knitfem.geometry.swatch.swatch_control_points`); the mechanics are the
B-spline model's own (:mod:`knitfem.bspline`).  Scene choices (issue 9):

* the knit yarn is naturally straight; the pre-stretch alpha shrinks its
  rest length to (1 - alpha) x its knitted length (the paper's "decrease the
  natural length in the stretching energy by the length ratio alpha");
* the tails are woven in (:func:`knitfem.geometry.swatch.swatch_ties`, the
  same ties as the beam scene): the knit yarn's ends to the nearest point of
  the bottom/top helix and each helix's ends to the nearest knit point, each
  held at its initial distance by a spring as stiff as a yarn piece that long
  (EA / L0);
* the bind-off helices keep their helix as natural shape (rest curvature and
  torsion, :mod:`knitfem.bspline.energy`), ``bindoff_stiffness`` times the
  yarn's EA and EI (default 10, as the beam scene: the paper notes the
  bind-off's stiffness changes the curl);
  their self-contact is kept (the paper drops it to save time; here it costs
  nothing);
* free-floating: no support at all; the six rigid motions are left to the
  solvers (zero force on them at every state) and lifted out of the stability check.
* friction: not modelled (the contact's tangential damping only changes the
  path, not the equilibrium).

Units: mm, g, s.  The constants and where each comes from: :class:`YarnConstants`.
"""
from dataclasses import dataclass, field

import numpy as np

from ..bspline import BSplineModel, ContactLaw, Yarn
from ..bspline.yarn import positive, segment_lengths
from ..geometry.swatch import plain_knit_swatch, swatch_control_points, swatch_ties

CM = 10.0                  # mm per cm


@dataclass(frozen=True)
class YarnConstants:
    """Yarn and relaxation constants, stored in the paper's units (g, cm, s)
    and converted to mm-g-s by the properties.

    k_len = 4.00e3 g cm^2/s^2, k_global = 1.00e-2 g/s: the paper (Tajiri et
        al., Sec. 6), its own choices.  Reading of k_len:
        Kaldor's stretching energy k_len (|r'| - 1)^2 per unit length of
        yarn, i.e. EA = 2 k_len per cm: EA = 8.00e3 g cm/s^2 = 8.00e4 g mm/s^2.
        (The paper's unit g cm^2/s^2 is an energy: per unit of the segment
        parameter, as in public re-implementations, EA would be 2 k_len / l_seg
        and depend on the segment length, which the paper does not give.)
        k_contact multiplies l l' f(d/2r) (energy per length^2, the same number
        in any length unit).  The paper gives 3.25 g/s^2 (:meth:`paper`); with
        it the yarns sink 30-60 % of a diameter into each other (measured on a
        4 x 4 swatch at alpha = 0.2), not a yarn state.  Default 3.25e3 g/s^2:
        the value of the public re-implementation of Kaldor (kContact = 3250),
        1000 x the paper's number (a g/kg slip?); overlap 1-2.5 % of d.
        k_global: the damping force -k_global v per cm of
        yarn, i.e. mass-proportional damping at rate k_global / (rho_l x 1 cm)
        = 1.67 1/s.
    line_density = 0.006 g/cm (6.0e-4 g/mm), radius_kaldor = 0.125 cm: Kaldor
        2008 as taken over by a public re-implementation of it
        (github.com/milmillin/knit-simulation, simulator/SimulatorParams.h:
        m = 0.006, r = 0.125); not checked against Kaldor's paper itself,
        which we could not read.  The swatch geometry keeps its own radius
        (shared scene input, default 0.4 mm: Kaldor's 1.25 mm would need
        loops w > 8r = 10 mm); the line density only sets the dynamics' time
        scale, never the equilibrium.
    ea_over_ei: EA/EI in 1/mm^2, EI = EA / ea_over_ei.  Kaldor's k_bend could
        not be sourced (the re-implementation's versions use 0.005, 0.05 and
        5 g cm^3/s^2); chosen so both models describe the same yarn: the beam
        scene's default (:mod:`knitfem.scenes.fabric`, 800 / mm^2, 3 % of a
        solid rod's 4/r^2 at r = 0.4 mm: yarn is far softer in bending than a
        rod relative to stretching; a solid rod's ratio crumples the knit).
    contact_damping, tangential_damping: normal and tangential contact
        damping (force per velocity per length^2), dynamic relaxation only;
        not given by the paper, chosen to damp a touching pair's relative
        motion about as fast as k_global damps the yarn.
    """
    k_len: float = 4.00e3                 # g cm^2/s^2 (paper)
    k_contact: float = 3.25e3             # g/s^2 (paper: 3.25, see above)
    k_global: float = 1.00e-2             # g/s (paper)
    line_density_cm: float = 0.006        # g/cm (Kaldor via re-implementation)
    radius_kaldor_cm: float = 0.125       # cm (Kaldor via re-implementation; not used)
    ea_over_ei: float = 800.0             # 1/mm^2 (the beam scene's default)
    contact_damping: float = 1.0e-2       # g/(s mm^2)
    tangential_damping: float = 1.0e-2    # g/(s mm^2)
    contact_form: str = "kaldor"          # or "smooth" (C2, not the paper's)

    @classmethod
    def paper(cls, **changes):
        """The paper's three constants as printed (k_contact = 3.25 g/s^2)."""
        return cls(k_contact=3.25, **changes)

    @property
    def EA(self):
        """Axial stiffness, g mm/s^2."""
        return 2.0 * self.k_len * CM        # 2 k_len per cm of yarn: g cm/s^2 -> g mm/s^2

    def EI(self, radius):
        """Bending stiffness (g mm^3/s^2); the same for every ``radius`` (mm)
        (kept as an argument: the ratio is the beam scene's, at r = 0.4 mm)."""
        return self.EA / self.ea_over_ei

    @property
    def line_density(self):
        """g/mm."""
        return self.line_density_cm / CM

    @property
    def damping_rate(self):
        """Mass-proportional damping coefficient k_global / (rho_l x 1 cm), 1/s."""
        return self.k_global / (self.line_density_cm * 1.0)

    def table(self, radius):
        """The constants in mm-g-s, for output."""
        return {"EA": self.EA, "EI": self.EI(radius), "ea_over_ei": self.EA / self.EI(radius),
                "k_contact": self.k_contact, "damping_rate": self.damping_rate,
                "line_density": self.line_density, "radius": radius,
                "bend_fraction": 4.0 * self.EI(radius) / (self.EA * radius**2),
                "contact_damping": self.contact_damping,
                "tangential_damping": self.tangential_damping,
                "contact_form": self.contact_form}


def point_parameters(points, segments):
    """Curve parameter t in [0, segments] of every polyline point: the
    chord-length parametrisation :func:`knitfem.bspline.curve.fit` used, so
    the spline at t_i is the material point that started at points[i]."""
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return chord / chord[-1] * segments


@dataclass
class BSplineSwatch:
    """A swatch (geometry), its B-spline model, and where every polyline point
    of every yarn sits on the splines (``params``)."""
    swatch: object
    model: BSplineModel
    params: list
    constants: YarnConstants
    alpha: float = 0.0
    initial_overlap: float = 0.0          # largest tube overlap / 2r at the start
    ties: list = field(default_factory=list)

    def points(self, q):
        """Deformed points of every yarn, stacked in ``swatch.points`` order."""
        from ..bspline import curve
        out = []
        for k, (yarn, t) in enumerate(zip(self.swatch.yarns, self.params)):
            o = self.model.offset[k]
            local = q[o:o + self.model.yarns[k].control.shape[0]]
            n = self.model.yarns[k].segments
            s = np.minimum(np.floor(t).astype(int), n - 1)
            B = curve.basis(t - s)                                       # (m, 4)
            out.append(np.einsum("mj,mjk->mk", B, local[s[:, None] + np.arange(4)]))
        return np.concatenate(out)


def bspline_swatch(n_wale, n_course, *, w=4.0, c=3.0, radius=0.4, segments_per_loop=16,
                   constants=None, bindoff_stiffness=10.0, ties=True, contact_skin=None,
                   knit_natural="straight"):
    """The B-spline model of an n_wale x n_course plain-knit swatch with bind-off
    (a :class:`BSplineSwatch`), at rest length = knitted length (alpha = 0;
    :func:`prestretch` applies alpha).  Sizes and counts as in
    :func:`~knitfem.geometry.swatch.plain_knit_swatch`; segments_per_loop: B-spline
    segments per loop length of yarn (>= 8).  knit_natural: "straight" (the
    paper's yarn) or "knitted" (the knit yarn's natural curvature and torsion
    are those of the knitted shape, so alpha = 0 is at rest; a yarn set by the
    knitting, its bending and torsion in their smooth forms:
    :func:`knitfem.bspline.energy.set_yarn_terms`)."""
    constants = YarnConstants() if constants is None else constants
    if knit_natural not in ("straight", "knitted"):
        raise ValueError(f"knit_natural must be 'straight' or 'knitted', got {knit_natural!r}")
    bindoff_stiffness = positive("bindoff_stiffness", bindoff_stiffness)
    if int(segments_per_loop) != segments_per_loop or segments_per_loop < 8:
        raise ValueError(f"segments_per_loop must be an integer >= 8, got {segments_per_loop!r}")
    ppl = max(32, 2 * int(segments_per_loop))        # polyline at least 2 points per segment
    swatch = plain_knit_swatch(n_wale, n_course, w, c, radius, points_per_loop=ppl)
    controls = swatch_control_points(swatch, int(segments_per_loop))
    EA, EI, rho = constants.EA, constants.EI(swatch.radius), constants.line_density
    yarns = []
    for k, (path, q) in enumerate(zip(swatch.yarns, controls)):
        helix = path.bindoff
        factor = bindoff_stiffness if helix else 1.0
        yarns.append(Yarn(q, segment_lengths(q), factor * EA, factor * EI,
                          radius=swatch.radius, line_density=rho,
                          curved=helix or knit_natural == "knitted", shaped=True,
                          set_yarn=knit_natural == "knitted" and not helix,
                          name="knit" if k == 0 else ("bindoff_bottom" if k == 1 else
                                                      "bindoff_top")))
    law = ContactLaw(constants.k_contact, swatch.radius, damping=constants.contact_damping,
                     tangential_damping=constants.tangential_damping,
                     form=constants.contact_form)
    model = BSplineModel(yarns, contact=law, contact_skin=contact_skin)
    params = [point_parameters(path.points, y.segments) for path, y in zip(swatch.yarns, yarns)]
    tied = swatch_ties(swatch) if ties else []
    q0 = model._initial()
    out = BSplineSwatch(swatch, model, params, constants, ties=tied)
    for ya, pa, yb, pb in tied:
        p = out.points(q0)
        start = np.concatenate([[0], np.cumsum([len(y.points) for y in swatch.yarns])])
        L0 = np.linalg.norm(p[start[ya] + pa] - p[start[yb] + pb])
        model.ties.add(ya, params[ya][pa], yb, params[yb][pb],
                       EA / max(L0, swatch.radius))
    from ..bspline.contact import overlap
    pts = model._at_samples(q0)
    out.initial_overlap = overlap(pts, model.contact_pairs(q0), law)
    return out


def prestretch(bswatch, alpha):
    """Shrink the knit yarn's rest length to (1 - alpha) x its knitted length
    (the bind-off keeps its own)."""
    alpha = float(alpha)
    if not (np.isfinite(alpha) and 0.0 <= alpha < 1.0):
        raise ValueError(f"alpha must be in [0, 1), got {alpha!r}")
    model = bswatch.model
    knit = model.yarn_of_segment == 0
    model.rest = np.where(knit, (1.0 - alpha) * model.rest0, model.rest0)
    model.speed = np.where(knit[:, None], (1.0 - alpha) * model.speed0, model.speed0)
    bswatch.alpha = alpha
