"""pkmlab: model, simulate and control parallel (closed-chain) manipulators.

Every machine — the paper's 3-RRR (Nasa & Bandyopadhyay, "Trajectory-tracking control of a planar 3-RRR
parallel manipulator"), the other presets, and any mechanism you describe — loads as one model type and
answers the same functions:

Examples
--------
>>> import pkmlab
>>> model = pkmlab.load("paper")
>>> fk = pkmlab.forward_kinematics(model, [1.6146, 1.9831, -1.1846])
>>> int(fk.count)
2
"""

from ._version import __version__

# The public names and the module that defines each. They are imported on first use (PEP 562),
# so that `import pkmlab` and `pkmlab --version` are instant, and Ctrl-C during start-up is
# handled by the command line rather than shown as a traceback.
_WHERE = {
    "MechanismModel": "model.mechanism_model", "load": "model.mechanism_model",
    "SingularityMap": "algorithms.analysis", "singularity_map": "algorithms.analysis",
    **dict.fromkeys(("Singularities", "singularity_kinds"), "algorithms.singularities"),
    **dict.fromkeys(("AssemblyError", "BranchFollowingError", "IncompleteSolutionWarning", "InvalidParameterError",
                     "PkmlabError", "SingularityError", "UnreachablePoseError", "UnstableControlError"), "errors"),
    **dict.fromkeys(("SINGULAR_S", "AssemblyMode", "ForwardKinematicsSolution", "InverseKinematicsSolution",
                     "acceleration_bias", "branch_following", "constraint_jacobian", "constraint_residual",
                     "coordinate_accelerations", "coordinate_jacobian", "coordinate_rates", "follow_path",
                     "forward_kinematics",
                     "inverse_kinematics", "singularity_measure", "velocity_jacobian", "working_modes",
                     "actuation_jacobian", "actuation_singularity_measure", "pose_coordinate_jacobian"),
                    "algorithms.kinematics"),
    **dict.fromkeys(("ActuatorSpaceModel", "ConstrainedDynamics", "FullSpaceModel", "actuator_space_model",
                     "constrained_dynamics", "forward_dynamics", "full_space_model", "inverse_dynamics"),
                    "algorithms.dynamics"),
    **dict.fromkeys(("DISTRIBUTIONS", "EffortDistribution", "PoseSpaceModel", "distribute_efforts",
                     "pose_space_model"), "algorithms.redundancy"),
    **dict.fromkeys(("BaseParameters", "base_parameters", "drive_parameter_names", "dynamics_regressor",
                     "inertial_parameter_names", "inertial_parameters", "random_states"), "algorithms.regressor"),
    **dict.fromkeys(("Identification", "Measurements", "filter_measurements", "identify"),
                    "algorithms.identification"),
    **dict.fromkeys(("ActuatorSpacePlant", "FullSpacePlant", "PlantRun"), "simulation.plants"),
    **dict.fromkeys(("load_scenario", "paper_scenario"), "formats.scenario"),
    "ControllerSpec": "control.controller",
    **dict.fromkeys(("TimeOptimal", "time_optimal"), "control.time_optimal"),
    **dict.fromkeys(("Scenario", "perturbed_model"), "simulation.scenario"),
    "SimulationResult": "simulation.result",
    **dict.fromkeys(("simulate", "simulate_batch"), "simulation.run"),
    **dict.fromkeys(("Study", "load_study", "sweep", "tune"), "study"),
    **dict.fromkeys(("draw", "plot", "show"), "views.notebook"),
}


def __getattr__(name: str):
    import importlib

    if name not in _WHERE:
        raise AttributeError(f"module 'pkmlab' has no attribute {name!r}")
    importlib.import_module("._compile_cache", __name__)  # the kernel cache, before any kernel is defined
    value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_WHERE})


__all__ = ["__version__", *_WHERE]


def _register_display() -> None:
    """In a running IPython (Jupyter), show pkmlab's objects as tables (:func:`pkmlab.views.notebook.register`)."""
    import sys

    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None and hasattr(ipython, "get_ipython") else None
    if shell is not None and hasattr(shell, "display_formatter"):
        from .views.notebook import register

        register(shell)


_register_display()
