"""ngsgel: polymer gels on NGSolve — swelling, large deformation, solvent diffusion, instabilities.

Submodules not re-exported here: ``ngsgel.patterns`` (wave, vertex and crease analysis),
``ngsgel.output`` (run folders, histories, VTK series, progress), ``ngsgel.scenes`` (the thesis's
scenes and studies, one module each; ``ngsgel list`` names them) and ``ngsgel.stability`` (spectra, buckling, imperfections; its main entry points are
re-exported).
"""

from .continuation import (Checkpoint, ContinuationError, Event, PathPoint, PathResult, Stabilization,
                           StabilityOptions, follow_path)
from .kinematics import (Axisymmetric, GeneralizedPlaneStrain, Kinematics, PlaneStrain, Solid3D, SphericalSymmetric,
                         kinematics_by_name)
from .materials import FloryRehnerGel, Material, NeoHookeanFilm
from .newton import LinearSolver, NewtonError, NewtonResult, Work, newton
from .problem import EquilibriumProblem, GelBody
from .shell import GelShell
from .stability import linear_buckling, load_rate, negative_count, random_field, seed_imperfection, spectrum
from .stepping import RampError, RampResult, RampStep, ValueReached, ramp
from .threads import set_threads, using_threads
from .transient import StepRecord, TransientError, TransientProblem, TransientResult, march, time_ramp

__version__ = "0.1.0"

__all__ = [
    "Axisymmetric", "Checkpoint", "ContinuationError", "EquilibriumProblem", "Event", "FloryRehnerGel",
    "GelBody", "GeneralizedPlaneStrain", "GelShell", "Kinematics", "LinearSolver", "Material", "NeoHookeanFilm", "NewtonError", "NewtonResult",
    "PathPoint", "PathResult", "PlaneStrain", "RampError", "RampResult", "RampStep", "Solid3D", "SphericalSymmetric",
    "Stabilization", "StabilityOptions", "StepRecord", "TransientError", "TransientProblem",
    "TransientResult", "follow_path", "kinematics_by_name", "linear_buckling", "load_rate", "march",
    "negative_count", "newton", "ramp", "random_field", "seed_imperfection", "set_threads", "spectrum", "time_ramp",
    "using_threads", "ValueReached", "Work",
]
