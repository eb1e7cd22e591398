"""Independent yarn-level model (Kaldor et al. 2008): B-spline centrelines,
stretching, bending and contact energies with exact gradients and Hessians,
dynamic relaxation, FIRE, Newton, stability.  Shares no
mechanics code with the beam model: only geometry input and output formats."""
from . import curve, stability
from .contact import ContactLaw
from .model import BSplineModel
from .yarn import Yarn
from .newton import relax_newton
from .relax import RelaxationError, relax_dynamic, relax_static

__all__ = ["curve", "stability", "BSplineModel", "ContactLaw", "RelaxationError", "Yarn",
           "relax_dynamic", "relax_newton", "relax_static"]
