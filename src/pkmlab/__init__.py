"""pkmlab: model, simulate and control parallel (closed-chain) manipulators.

The first mechanism is the planar 3-RRR of Nasa & Bandyopadhyay, "Trajectory-tracking
control of a planar 3-RRR parallel manipulator". Start with :class:`Planar3RRR`:

>>> import pkmlab
>>> model = pkmlab.Planar3RRR.paper()
>>> fk = pkmlab.forward_kinematics(model, [1.6146, 1.9831, -1.1846])
>>> int(fk.count)
2
"""

from . import (
    _compile_cache,  # noqa: F401  (must precede the compiled modules)
    dynamics,
)
from .analysis import SingularityMap, singularity_map
from .errors import (
    AssemblyError,
    BranchFollowingError,
    InvalidParameterError,
    PkmlabError,
    SingularityError,
    UnreachablePoseError,
)
from .geometry import WORKING_MODES, Planar3RRR
from .kinematics import (
    AssemblyMode,
    ForwardKinematicsSolution,
    InverseKinematicsSolution,
    acceleration_bias,
    actuated_jacobian,
    branch_following,
    constraint_jacobian,
    constraint_residual,
    coordinate_accelerations,
    coordinate_rates,
    forward_kinematics,
    forward_singularity_determinant,
    inverse_kinematics,
    passive_jacobian,
    passive_rates,
    platform_jacobian,
    platform_pose,
    singularity_measure,
    velocity_jacobian,
    working_mode_of,
)
from .plant import FullPlant, PlantRun, ReducedPlant
from .scenario_io import load_scenario
from .simulation import Scenario, SimulationResult, paper_scenario, perturbed_model, simulate, simulate_batch

__version__ = "0.1.0"

__all__ = [
    "Planar3RRR",
    "WORKING_MODES",
    "PkmlabError",
    "InvalidParameterError",
    "UnreachablePoseError",
    "SingularityError",
    "BranchFollowingError",
    "AssemblyError",
    "InverseKinematicsSolution",
    "ForwardKinematicsSolution",
    "AssemblyMode",
    "inverse_kinematics",
    "forward_kinematics",
    "branch_following",
    "platform_pose",
    "constraint_residual",
    "constraint_jacobian",
    "passive_jacobian",
    "actuated_jacobian",
    "velocity_jacobian",
    "platform_jacobian",
    "passive_rates",
    "coordinate_rates",
    "acceleration_bias",
    "coordinate_accelerations",
    "forward_singularity_determinant",
    "singularity_measure",
    "working_mode_of",
    "dynamics",
    "Scenario",
    "SimulationResult",
    "paper_scenario",
    "perturbed_model",
    "simulate",
    "simulate_batch",
    "load_scenario",
    "ReducedPlant",
    "FullPlant",
    "PlantRun",
    "SingularityMap",
    "singularity_map",
]
