"""ngsgel: polymer gels on NGSolve — swelling, large deformation, solvent diffusion, instabilities."""

from .kinematics import Axisymmetric, Kinematics, PlaneStrain, Solid3D, SphericalSymmetric, kinematics_by_name
from .materials import FloryRehnerGel, Material, NeoHookeanFilm
from .newton import LinearSolver, NewtonError, NewtonResult, newton
from .problem import EquilibriumProblem, GelBody
from .stepping import RampError, RampResult, ramp

__version__ = "0.1.0"

__all__ = [
    "Axisymmetric", "EquilibriumProblem", "FloryRehnerGel", "GelBody", "Kinematics", "LinearSolver",
    "Material", "NeoHookeanFilm", "NewtonError", "NewtonResult", "PlaneStrain", "RampError",
    "RampResult", "Solid3D", "SphericalSymmetric", "kinematics_by_name", "newton", "ramp",
]
