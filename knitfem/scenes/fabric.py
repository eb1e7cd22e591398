"""A plain-knit swatch as a beam scene: every yarn a Simo-Reissner rod, penalty
contact with regularised Coulomb friction, the yarn's tails tied into the
bind-off, free-floating (paper Sec. 6, Fig. 5).

Units: mm and N (EI in N mm^2).  Only ratios shape the result: scaling EI,
GJ, EA, the penalty and the ties together leaves every equilibrium unchanged
(tested), so the yarn is given by its slenderness and the stiffness ratios.

The scene, and why each choice (measured on 5 x 5 and 7 x 7 swatches while
building it; see README "Fabric curling"):

* **Yarn.**  Naturally straight (the paper's rod).  Bending-to-stretching
  ratio EA/EI = ``ea_over_ei`` (default 800 /mm^2 for r = 0.4 mm: a solid
  rod has 4/r^2 = 25 /mm^2; a twisted yarn is 1-5 % as stiff in bending
  relative to stretching, the range where the paper's model stays a fabric).
  GJ/EI = ``gj_over_ei`` (2/3: nu = 0.5).
* **Pre-stretch** alpha: the yarn's rest length is (1 - alpha) x its knitted
  length (the knitted shape is the yarn stretched by the knitting weight).
* **Bind-off**: the helices keep their helix as natural shape ("helically
  bent rods"), ``bindoff_stiffness`` times the yarn's stiffness (the paper
  notes the bind-off's stiffness matters; with 1x they uncoil and the edge
  loops slide off).  Their length stays the knitted one unless
  ``bindoff_prestretch`` (then the 10 x 35 rolls its top and bottom more
  than a turn: a strong control of the curl, README).
* **Tails tied in**: the knit yarn's two ends and each helix's two ends are
  tied (stiff springs at the layout distance) to the nearest point of the
  other yarn (:func:`knitfem.geometry.swatch.swatch_ties`), as a knitter weaves
  the tails in: a free tail lets the pre-stretch drain out.  ``tail_ties`` n
  > 1 ties each tail's last n points, each to the two nearest, so it cannot
  pivot about one tie (22-25 % fewer steps on 4 x 4 and 5 x 5, 9 % on 10 x 10).
* **Friction** mu (default 0.3, cotton on cotton): without it a frictionless
  knit of naturally straight yarn is not held together by anything but its
  topology, and it collapses (the courses slide together, then it tangles:
  measured with and without pre-stretch, with ties and stiff bind-off).
  ``corotated_friction`` (default): each slip measured in the master yarn's
  frame turned since the friction round began
  (:mod:`knitfem.contact.corotated`); in the fixed tangent planes of the
  round's start instead, the rounds did not settle at alpha 0.2 and the
  friction's net moment held the free-floating swatch with 44-78 % of the
  force scale (3 x 4 .. 5 x 5), co-rotated ~2e-7.
* **Contact**: penalty ``penalty`` EI/r^4 (1000: the pre-stretch tension
  presses the yarns together harder than the default's design load), skin
  g0 = 5 % of d.  The geometry is knitted with an inflated radius so that no
  chord pair starts inside the skin: with this penalty, a pair half-way into
  the skin already carries a line load of ~15 EI/r^3, far from the stress-free
  start the homotopy needs.
* **Contact quadrature**: 12 Gauss points per yarn diameter along each slave
  segment (the library's default is 6): as yarns slide, the contact line
  integral ripples with the Gauss point spacing; with 6 that ripple stalled
  the minimisation of a 5 x 5 swatch at a residual of 2e-3 (line-search steps
  of 1e-3 along a sliding mode), with 12 it relaxes to 1e-8.
* **Rigid motion**: one node held (statically determinate: its reactions
  vanish at equilibrium and are reported).
"""
from dataclasses import MISSING, asdict, dataclass, fields, replace

import numpy as np

from ..beam import BeamModel, Rod, Section
from ..geometry.swatch import mirror_swatch, plain_knit_swatch, swatch_ties

DEFAULT_EA_OVER_EI = 800.0      # 1/mm^2: 3 % of a solid rod's 4/r^2 at r = 0.4 mm


@dataclass(frozen=True)
class FabricScene:
    """Parameters of a swatch scene (lengths in mm)."""
    nw: int
    nc: int
    w: float = 4.0
    c: float = 3.0
    radius: float = 0.4
    # 16 per loop locks the yarn's sliding through its crossings (at alpha 0.2
    # a 5 x 5 kept 2.5 % of pre-stretch and 5 x the energy; 24, 32 and 40 per
    # loop agree on the energy path to a few %: README, "elements per loop");
    # 32 rather than 24 for its smaller radius inflation (0.06 against 0.08)
    # at the same measured run time.  (A 10 x 10 at alpha 0.2 lands on one of
    # two equilibria whatever the level: double at 24 and 48, top/bottom at 32
    # and 40: README)
    elements_per_loop: int = 32
    alpha: float = 0.2
    ea_over_ei: float = DEFAULT_EA_OVER_EI
    gj_over_ei: float = 2.0 / 3.0
    bindoff_stiffness: float = 10.0
    friction: float = 0.3
    penalty: float = 1000.0
    regularisation: float = 0.05
    per_diameter: int = 12
    slip: float = 0.02              # friction's stick slip, fraction of the radius
    ties: bool = True
    # points of each tail tied (1: its end, to the nearest point; n > 1: its
    # last n points, each to the two nearest: the tail's direction held too)
    tail_ties: int = 1
    EI: float = 1.0                 # N mm^2 (nominal: only ratios matter)
    mirror: bool = False            # knitted from the other side (geometry.mirror_swatch)
    corotated_friction: bool = True    # friction planes turn with the master yarn in a round
    # the bind-off helices' rest length shrinks by alpha with the knit yarn's
    # (they keep their helix: the same turns over the shorter length); off, the
    # knit edge ends narrower than its bind-off (see Homotopy)
    bindoff_prestretch: bool = False
    # the radius inflation the swatch is knitted with (fraction); None: the
    # smallest multiple of 0.02 that keeps the contact clear (see build).  It
    # grows as the elements per loop fall (5 x 5: 0.12 at 16 per loop, 0.08 at
    # 24, 0.06 at 32-48), so a refinement study holds it fixed
    inflation: float = None
    # the share of the knitted curvature the knit yarn loses over the homotopy:
    # 1, naturally straight (the paper's yarn); 0, it keeps its knitted shape
    # as its natural shape (a yarn set by knitting, pre-stretched all the same)
    straighten: float = 1.0

    def as_dict(self):
        return asdict(self)

    @classmethod
    def stored(cls, record):
        """The scene a stored record (a checkpoint's or summary's ``scene``
        dict) was run with.  A field the record predates ran with its default
        -- the behaviour before the field existed -- except where the default
        changed since (:data:`DEFAULTS_BEFORE`).  ValueError names a field
        the record has and this scene does not."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(record) - known)
        if unknown:
            raise ValueError(f"scene fields {unknown} are not FabricScene fields "
                             f"(a record from other code?)")
        defaults = {f.name: f.default for f in fields(cls) if f.default is not MISSING}
        return cls(**{**defaults, **DEFAULTS_BEFORE, **record})


# defaults that changed after records were stored, as they were: friction
# planes fixed at a round's start until the co-rotated friction became the
# default (the elements per loop have always been stored)
DEFAULTS_BEFORE = {"corotated_friction": False}


def yarn_section(scene, factor=1.0):
    """Section of the knit yarn (``factor`` scales every stiffness)."""
    EI = scene.EI * factor
    EA = scene.ea_over_ei * EI
    # shear stiffness of a nu = 0.5 solid (its value hardly matters: shear strains stay tiny)
    return Section(EA=EA, GA2=EA / 3.0, GA3=EA / 3.0, GJ=scene.gj_over_ei * EI, EI2=EI, EI3=EI,
                   radius=scene.radius)


def _model(scene, swatch):
    """The beam model of a knitted swatch (natural strains at the knitted shape)."""
    knit = yarn_section(scene)
    bind = yarn_section(scene, scene.bindoff_stiffness)
    model = BeamModel()
    for k, yarn in enumerate(swatch.yarns):
        model.add_rod(Rod.from_centerline(yarn.points, knit if k == 0 else bind,
                                          tangents=yarn.tangents, natural="shape",
                                          name="knit" if k == 0 else
                                          ("bindoff_bottom" if k == 1 else "bindoff_top")))
    if scene.ties:
        for ya, pa, yb, pb in swatch_ties(swatch, scene.tail_ties):
            model.tie(ya, pa, yb, pb)
    model.contact(factor=scene.penalty, regularisation=scene.regularisation,
                  per_diameter=scene.per_diameter, friction=scene.friction,
                  slip=scene.slip * scene.radius, corotated=scene.corotated_friction)
    return model


def build(scene, max_tries=10):
    """(model, swatch, info): the beam model of the scene with its natural
    strains at the knitted shape (the homotopy's start, see :class:`Homotopy`).

    The swatch is knitted with an inflated radius r (1 + delta), delta raised
    in steps of 0.02 until the model's own contact (its chords, master curves,
    slave Gauss points) sees no pair inside the skin g0 at the start; or with
    ``scene.inflation`` as delta, refused (naming it and the automatic
    choice) if that leaves a pair inside the skin."""
    g0 = scene.regularisation * 2.0 * scene.radius

    def knit(delta):
        swatch = plain_knit_swatch(scene.nw, scene.nc, scene.w, scene.c,
                                   scene.radius * (1.0 + delta),
                                   points_per_loop=scene.elements_per_loop)
        if scene.mirror:
            swatch = mirror_swatch(swatch)
        model = _model(scene, swatch)
        return swatch, model, model.contact_report(model.initial_state()).min_gap
    if scene.inflation is not None:
        delta = float(scene.inflation)
        fits = scene.radius * (1.0 + delta) < scene.w / 8
        if not (np.isfinite(delta) and 0.0 <= delta and fits):
            raise ValueError(f"inflation must be in [0, {scene.w / 8 / scene.radius - 1:.3g}) "
                             f"(the knitted radius below w/8), got {scene.inflation!r}")
        swatch, model, min_gap = knit(delta)
        if not min_gap >= 1.02 * g0:
            auto = build(replace(scene, inflation=None), max_tries)[2]["inflation"]
            raise ValueError(f"inflation {delta:g} leaves yarns {min_gap:.3g} mm apart at "
                             f"{scene.elements_per_loop} elements per loop, inside the contact "
                             f"skin {g0:.3g} mm (valid: inflation >= {auto:g}, the automatic "
                             f"choice, or more --elements-per-loop)")
        return _finish(scene, model, swatch, delta, min_gap)
    delta, min_gap = 0.0, -np.inf
    for _ in range(max_tries):
        if scene.radius * (1.0 + delta) >= scene.w / 8.0:
            break
        swatch, model, min_gap = knit(delta)
        if min_gap >= 1.02 * g0:
            break
        delta += 0.02
    if not min_gap >= 1.02 * g0:
        raise ValueError(f"radius {scene.radius:g} is too thick for w = {scene.w:g} at "
                         f"{scene.elements_per_loop} elements per loop: no knitted geometry keeps "
                         f"the yarns {g0:.3g} apart (valid: radius well below w/8 = "
                         f"{scene.w / 8:g}, or more --elements-per-loop)")
    return _finish(scene, model, swatch, delta, min_gap)


def _finish(scene, model, swatch, delta, min_gap):
    """Length scale, the held node and the build's info."""
    model.set_length_scale(swatch.loop.w)
    held = model.free_body()
    info = {"inflation": delta, "start_gap_over_d": min_gap / (2.0 * scene.radius),
            "held_node": held, "dofs": 6 * model.assembly.n_nodes,
            "free_dofs": int(np.count_nonzero(~model.fixed)),
            "loop_length": swatch.loop.length, "length_scale": swatch.loop.w}
    return model, swatch, info


def yarn_axial_strain(model, state):
    """(median, max) axial strain of the knit yarn over its current rest
    length (the homotopy's natural strain) at ``state``: how much of the
    pre-stretch the yarn still holds.  A knit whose yarn slides through its
    crossings drains it (1e-4 at 24 elements per loop, 5 x 5, alpha 0.2);
    at 16 per loop the same swatch kept a median 2.5 % (README: the coarse
    chords lock the sliding)."""
    asm = model.assembly
    gamma = asm.strains(state.x, state.q)[0]
    knit = asm.rod_of_element == 0
    strain = gamma[knit, 0] / asm.gamma0[knit, 0] - 1.0
    return float(np.median(strain)), float(strain.max())


class Homotopy:
    """Natural strains of the knit yarn from its knitted shape (lam = 0, stress
    free) to straight with rest length (1 - alpha) x knitted (lam = 1); the
    bind-off keeps its helix.  In two stages, as on the knitting machine: up
    to lam = ``split`` the rest length shrinks (the yarn, still shaped as
    knitted, tightens onto its crossings, which press together: friction
    takes hold), then the natural curvature goes (the loops try to
    straighten, held by that friction).  Released together, the loops first
    slide freely (no contact carries load yet) and a 5 x 5 swatch needed
    120 iterations per 5 % of the path.  Strains are per reference (knitted)
    length: the rest-length change enters as the natural axial strain
    1 - alpha and all stiffnesses per unit rest length.

    ``bindoff``: the bind-off helices' rest length shrinks with the knit's in
    the stretch stage; their natural curvature per knitted length stays (the
    same turns, one per stitch, over the shorter length).  Without it the
    helices keep their knitted length while the knit under them shrinks, so a
    bind-off edge is longer than the knit it closes and its helix buckles out
    (the suspected cause of a 10 x 35 tube's flared ends -- rejected: with the
    shrink its top and bottom roll more than a full turn, README).

    ``straighten``: the share of the knitted curvature (and shear) the knit
    yarn loses by lam = 1 (1: naturally straight, the paper's yarn; 0: its
    natural shape stays the knitted one, only its rest length shrinks)."""

    @classmethod
    def of_scene(cls, model, scene):
        """The homotopy of a :class:`FabricScene`'s model (its alpha and
        bind-off pre-stretch: what ``knitfem curl`` relaxes along)."""
        return cls(model, scene.alpha, bindoff=scene.bindoff_prestretch,
                   straighten=scene.straighten)

    def __init__(self, model, alpha, split=0.3, bindoff=False, straighten=1.0):
        straighten = float(straighten)
        if not 0.0 <= straighten <= 1.0:
            raise ValueError(f"straighten must be in [0, 1] (the share of the knitted "
                             f"curvature the yarn loses), got {straighten!r}")
        asm = model.assembly
        self.assembly = asm
        self.knit = asm.rod_of_element == 0
        self.shrinks = np.ones_like(self.knit) if bindoff else self.knit
        self.gamma_shape, self.kappa_shape = asm.gamma0.copy(), asm.kappa0.copy()
        self.CN, self.CM = asm.CN.copy(), asm.CM.copy()
        self.alpha = float(alpha)
        self.split = float(split) if alpha > 0 else 0.0
        self.straighten = straighten

    def apply(self, lam):
        asm, k = self.assembly, self.knit
        stretch = min(1.0, lam / self.split) if self.split > 0 else 1.0
        bend = self.straighten * max(0.0, (lam - self.split) / (1.0 - self.split))
        # energy per rest length h0 = s h: W = h/(2 s) C (strain - s e1)^2 per knitted length h
        s = 1.0 - stretch * self.alpha
        shrinks = self.shrinks
        asm.gamma0[shrinks] = self.gamma_shape[shrinks] * s
        asm.CN[shrinks] = self.CN[shrinks] / s
        asm.CM[shrinks] = self.CM[shrinks] / s
        asm.gamma0[k, 1:] *= 1.0 - bend
        asm.kappa0[k] = (1.0 - bend) * self.kappa_shape[k]
