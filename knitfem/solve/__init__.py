"""Solvers that know nothing of beams: Newton, load stepping."""
from .newton import NewtonError, NewtonResult, newton
from .stepping import Step, SteppingError, load_stepping

__all__ = ["NewtonError", "NewtonResult", "newton", "Step", "SteppingError", "load_stepping"]
