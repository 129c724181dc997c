"""``pkmlab dynamics``: the dynamic model at a state, for every assembly mode or the one nearest ``--near``, of
every machine through one model type and one schema:

``{"mechanism", "pose_names", "tau_from", "solutions": [{"pose", "passive", "S", "M", "c", "g", "tau",
"multipliers"}, ...]}`` — the actuator-space model ``M θ̈ + c + g = τ`` (eq. 35 with gravity; ``c = C θ̇``) and
the loop-closure multipliers ``λ`` (eq. 26) of the full model moving at ``θ̇`` under the tau_used ``tau``: those of
``--tau``, else ``c + g`` (zero actuator acceleration), as ``"tau_from"`` says.
"""

from __future__ import annotations

import sys

from ..errors import AssemblyError, InvalidParameterError, SingularityError
from ._common import check_count, mechanism_name, model_of, pose_gap, shown, warn_near_singularity
from .kinematics import heading, passive_names, passive_of

#: ``--near`` farther than this (metres and radians, as ``nearest`` measures) from every assembly
#: mode is said: the mode reported is not the one asked for.
NEAR_TOLERANCE = 1e-3
#: ``"tau_from"``: where the tau_used under which the multipliers are computed come from.
TAU_GIVEN, TAU_HOLDING = "--tau", "c + g (zero actuator acceleration)"


def _overflow(where: str, flag: str, theta_dot) -> InvalidParameterError:
    return InvalidParameterError(f"{where}: the dynamic model overflows at {flag} {shown(theta_dot)} (beyond "
                                 "floating-point range)")


def _far_from_near(near, pose) -> None:
    """Say on stderr that the assembly mode reported is not near the pose ``--near`` asked for."""
    print(f"pkmlab dynamics: warning: no assembly mode is within {NEAR_TOLERANCE:g} of --near {shown(near)}; the "
          f"nearest, reported, is at pose ({', '.join(f'{v:.6f}' for v in pose)})", file=sys.stderr)


def _record(model, mode, theta_dot, tau, flag: str) -> dict:
    """One assembly mode's model: refused at a singularity or where the rates (or the efforts) overflow it."""
    import numpy as np

    from ..algorithms.dynamics import actuator_space_model, constrained_dynamics
    from ..algorithms.kinematics import SINGULAR_S, coordinate_rates

    pose = mode.pose.tolist()
    where = f"the assembly mode at pose ({', '.join(f'{v:.6f}' for v in pose)})"
    # Below SINGULAR_S the actuator-space model is refused. Near a singularity two assembly modes merge into a
    # double root of the forward-kinematics polynomial, found only to about √ε ≈ 1e-8 (measured: S = 2e-8 where
    # inverse kinematics gives 9e-11); Mθ grows as 1/S², so below 1e-6 its numbers are off by more than 1 % —
    # and a change of θ in the 7th digit changes them completely.
    if not abs(mode.S) >= SINGULAR_S:
        raise SingularityError(f"{where} is at a gain-type singularity (S = {mode.S:.3g}): the actuator-space "
                               "model (eq. 35) does not exist there")
    with np.errstate(all="ignore"):
        try:
            actuator_space = actuator_space_model(model, mode.q, theta_dot)
            q_dot = coordinate_rates(model, mode.q, theta_dot)
        except InvalidParameterError:  # the library's "theta_dot overflows": said with the option typed
            raise _overflow(where, flag, theta_dot) from None
        tau_used = actuator_space.c + actuator_space.g if tau is None else np.asarray(tau, dtype=float)
        try:
            motion = constrained_dynamics(model, mode.q, q_dot, tau_used)
        except InvalidParameterError:
            raise _overflow(where, flag if tau is None else f"{flag} and --tau",
                            theta_dot if tau is None else [*theta_dot, *tau]) from None
    values = (actuator_space.M, actuator_space.c, actuator_space.g, tau_used, motion.multipliers)
    if not all(np.all(np.isfinite(v)) for v in values):
        raise _overflow(where, flag, theta_dot)
    record = {"pose": pose, "passive": passive_of(model, mode.q), "S": mode.S, "M": actuator_space.M.tolist(),
              "c": actuator_space.c.tolist(), "g": actuator_space.g.tolist(), "tau": tau_used.tolist(),
              "multipliers": motion.multipliers.tolist()}
    warning = warn_near_singularity("dynamics", where, mode.S, "M and c grow as 1/S^2, the multipliers without "
                                    "bound, and they are very sensitive to the actuators")
    if warning:
        record["warning"] = warning
    return record


def _print(model, records, tau_from: str) -> None:
    names, passive = model.pose_names, passive_names(model)

    def row(values) -> str:
        return "  ".join(f"{v:+.6e}" for v in values)

    for rec in records:
        print("assembly mode at " + ", ".join(f"{k} = {v:+.6f}" for k, v in zip(names, rec["pose"], strict=True))
              + f", S = {rec['S']:+.6f}")
        if passive:
            print(f"  passive ({', '.join(passive)}): {row(rec['passive'])}")
        print("  M (actuator space):")
        for line in rec["M"]:
            print("    " + row(line))
        print(f"  c = C theta_dot: {row(rec['c'])}")
        print(f"  g (gravity): {row(rec['g'])}")
        print(f"  tau{' = c + g, zero actuator acceleration' if tau_from == TAU_HOLDING else ' (--tau)'}: "
              f"{row(rec['tau'])}")
        print(f"  multipliers (loop closures, eq. 26): {row(rec['multipliers'])}")


def cmd_dynamics(args) -> dict:
    """``dynamics THETA... [--theta-dot W...] [--tau T...] [--near POSE...] [--mechanism M]``: the model of every
    assembly mode of the actuator values, or of the one nearest ``--near``."""
    from ..algorithms.kinematics import forward_kinematics, refuse_actuation_redundancy

    model = model_of(args)
    refuse_actuation_redundancy(model, "pkmlab dynamics (the actuator-space model)")
    n, names = model.n_actuators, model.pose_names
    flag = getattr(args, "theta_dot_flag", None) or "--theta-dot"  # the spelling typed, for the messages
    check_count(args, args.theta, n, "the actuator values")
    theta_dot = [0.0] * n if args.theta_dot is None else args.theta_dot
    check_count(args, theta_dot, n, flag)
    if args.tau is not None:
        check_count(args, args.tau, n, "--tau")
    if args.near is not None:
        check_count(args, args.near, len(names), f"--near ({', '.join(names)})")
    found = forward_kinematics(model, args.theta)
    if len(found) == 0:
        raise AssemblyError(f"theta = {shown(args.theta)} cannot be assembled: forward kinematics of the "
                            f"{model.name} has no real solution")
    chosen = list(found)
    if args.near is not None:
        chosen = [found.nearest(args.near)]
        if pose_gap(chosen[0].pose, args.near, names) > NEAR_TOLERANCE:
            _far_from_near(args.near, chosen[0].pose)
    tau_from = TAU_HOLDING if args.tau is None else TAU_GIVEN
    records = [_record(model, mode, theta_dot, args.tau, flag) for mode in chosen]
    if not args.json:
        print(heading(args, model, "dynamics") + f" at theta = {shown(args.theta)}, theta_dot = {shown(theta_dot)}: "
              + (f"{len(records)} assembly mode(s)" if args.near is None else "the assembly mode nearest --near"))
        _print(model, records, tau_from)
    return {"mechanism": mechanism_name(args, model), "pose_names": list(names), "tau_from": tau_from,
            "solutions": records}
