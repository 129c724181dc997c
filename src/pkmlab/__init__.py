"""pkmlab: model, simulate and control parallel (closed-chain) manipulators.

The first mechanism is the planar 3-RRR of Nasa & Bandyopadhyay, "Trajectory-tracking
control of a planar 3-RRR parallel manipulator". Start with :class:`Planar3RRR`:

>>> import pkmlab
>>> model = pkmlab.Planar3RRR.paper()
>>> fk = pkmlab.forward_kinematics(model, [1.6146, 1.9831, -1.1846])
>>> int(fk.count)
2
"""

from ._version import __version__

# The public names and the module that defines each. They are imported on first use (PEP 562),
# so that `import pkmlab` and `pkmlab --version` are instant, and Ctrl-C during start-up is
# handled by the command line rather than shown as a traceback.
_WHERE = {
    "dynamics": None,  # a module
    "SingularityMap": "analysis", "singularity_map": "analysis",
    **dict.fromkeys(("AssemblyError", "BranchFollowingError", "IncompleteSolutionWarning", "InvalidParameterError",
                     "PkmlabError", "SingularityError", "UnreachablePoseError", "UnstableControlError"), "errors"),
    "WORKING_MODES": "geometry", "Planar3RRR": "geometry",
    **dict.fromkeys(("AssemblyMode", "ForwardKinematicsSolution", "InverseKinematicsSolution", "acceleration_bias",
                     "actuated_jacobian", "branch_following", "constraint_jacobian", "constraint_residual",
                     "coordinate_accelerations", "coordinate_rates", "forward_kinematics",
                     "forward_singularity_determinant", "inverse_kinematics", "passive_jacobian", "passive_rates",
                     "platform_jacobian", "platform_pose", "singularity_measure", "velocity_jacobian",
                     "working_mode_of"), "kinematics"),
    **dict.fromkeys(("FullPlant", "PlantRun", "ReducedPlant"), "plant"),
    "load_scenario": "scenario_io",
    "ControllerSpec": "control",
    **dict.fromkeys(("Scenario", "SimulationResult", "paper_scenario", "perturbed_model", "simulate",
                     "simulate_batch"), "simulation"),
    **dict.fromkeys(("Study", "load_study", "sweep", "tune"), "study"),
    "show": "views.notebook",
}


def __getattr__(name: str):
    import importlib

    if name not in _WHERE:
        raise AttributeError(f"module 'pkmlab' has no attribute {name!r}")
    importlib.import_module("._compile_cache", __name__)  # the kernel cache, before any kernel is defined
    module = _WHERE[name]
    value = (importlib.import_module(f".{name}", __name__) if module is None
             else getattr(importlib.import_module(f".{module}", __name__), name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_WHERE})


__all__ = [
    "__version__",
    "ControllerSpec",
    "Planar3RRR",
    "WORKING_MODES",
    "PkmlabError",
    "InvalidParameterError",
    "UnreachablePoseError",
    "UnstableControlError",
    "SingularityError",
    "BranchFollowingError",
    "AssemblyError",
    "IncompleteSolutionWarning",
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
    "Study",
    "load_study",
    "sweep",
    "tune",
    "show",
]
