"""``pkmlab dynamics``: the dynamic model at a state, for every assembly mode or the one nearest ``--near``."""

from __future__ import annotations

import sys

from ..errors import AssemblyError, InvalidParameterError, SingularityError
from ._common import check_count, mechanism_of, paper_manipulator

#: Below this |S| the actuator-space model is refused. Near a singularity two assembly modes
#: merge into a double root of the forward-kinematics polynomial, found only to about √ε ≈ 1e-8
#: (measured: S = 2e-8 where inverse kinematics gives 9e-11); Mθ grows as 1/S², so below 1e-6 its
#: numbers are off by more than 1 % — and a change of θ in the 7th digit changes them completely.
SINGULAR_S = 1e-6
#: ``--near`` farther than this (metres and radians, as ``nearest`` measures) from every assembly
#: mode is said: the mode reported is not the one asked for.
NEAR_TOLERANCE = 1e-3
#: Below this |S| (the default run-time singularity guard) the model is reported with a warning.
NEAR_SINGULAR_S = 1e-2


def _screen_model(where: str, s: float, values, flag: str, rates) -> None:
    """Refuse an actuator-space model that means nothing: at a singularity (``|S| < SINGULAR_S``) or
    overflowed (``values`` not finite, for the rates given with ``flag``)."""
    import numpy as np

    if abs(s) < SINGULAR_S:
        raise SingularityError(f"{where} is at a gain-type singularity (S = {s:.3g}): the actuator-space model "
                               "(eq. 35) does not exist there")
    if not all(np.all(np.isfinite(v)) for v in values):
        raise InvalidParameterError(f"{where}: the dynamic model overflows at {flag} "
                                    f"{' '.join(f'{w:g}' for w in rates)} (beyond floating-point range)")


def _near_singularity(where: str, s: float, grows: str) -> str | None:
    """The warning for ``|S| < NEAR_SINGULAR_S`` (also said on stderr), or None."""
    from .._format import apart

    if abs(s) >= NEAR_SINGULAR_S:
        return None
    shown, limit = apart(abs(s), NEAR_SINGULAR_S)
    warning = (f"near a gain-type singularity (|S| = {shown} < {limit}): {grows} grow as 1/S^2 and are very "
               "sensitive to the actuators")
    print(f"pkmlab dynamics: warning: {where} is {warning}", file=sys.stderr)
    return warning


def _far_from_near(near, pose) -> None:
    """Say on stderr that the assembly mode reported is not near the pose ``--near`` asked for."""
    print(f"pkmlab dynamics: warning: no assembly mode is within {NEAR_TOLERANCE:g} of --near "
          f"{' '.join(f'{v:g}' for v in near)}; the nearest, reported, is at pose "
          f"({', '.join(f'{v:.6f}' for v in pose)})", file=sys.stderr)


def _dynamics_record(model, sol_q, theta_dot) -> dict:
    import numpy as np

    from .. import dynamics
    from ..kinematics import coordinate_rates, platform_pose, singularity_measure

    x, y, alpha = platform_pose(model, sol_q).tolist()
    where = f"the assembly mode at pose ({x:.6f}, {y:.6f}, {alpha:.6f})"
    s = float(singularity_measure(model, sol_q))
    _screen_model(where, s, (), "--theta-dot", theta_dot)
    with np.errstate(all="ignore"):
        q_dot = coordinate_rates(model, sol_q, theta_dot)
        m_theta, c_theta = dynamics.actuator_space_model(model, sol_q, theta_dot)
        _qdd, lam = dynamics.constrained_accelerations(model, sol_q, q_dot, [0.0, 0.0, 0.0])
        record = {
            "pose": {"x": x, "y": y, "alpha": alpha},
            "S": s,
            "q": sol_q.tolist(),
            "q_dot": q_dot.tolist(),
            "M_theta": m_theta.tolist(),
            "c_theta": c_theta.tolist(),
            "C_theta": dynamics.actuator_space_coriolis_matrix(model, sol_q, theta_dot).tolist(),
            "M": dynamics.mass_matrix(model, sol_q).tolist(),
            "lambda": lam.tolist(),
            "kinetic_energy": float(dynamics.kinetic_energy(model, sol_q, q_dot)),
        }
    _screen_model(where, s, [v for v in record.values() if not isinstance(v, dict)], "--theta-dot", theta_dot)
    warning = _near_singularity(where, s, "M_theta and lambda")
    if warning:
        record["warning"] = warning
    return record


def _pose_gap(pose, other, names) -> float:
    """How far apart two poses are, metres and radians together (angles the short way round), as
    ``--near`` measures it."""
    import math

    return math.hypot(*[math.remainder(a - b, 2 * math.pi) if name == "alpha" else a - b
                        for a, b, name in zip(pose, other, names, strict=True)])


def cmd_dynamics_mechanism(args) -> dict:
    """``dynamics --mechanism M ACTUATORS... [--rates W...] [--near POSE...]``: ``{"M", "c", "g", "S", "pose"}``
    of ``M θ̈ + c + g = τ`` (eq. 35 with gravity) for the assembly mode nearest ``--near`` (else every mode,
    under ``"solutions"``)."""

    import numpy as np

    from .. import mechanism_model as mm

    model = mechanism_of(args)
    n, names = model.n_actuators, model.description.pose_names
    check_count(args, args.actuators, n, "the actuator values")
    rates = [0.0] * n if args.theta_dot is None else args.theta_dot
    check_count(args, rates, n, "--rates")
    found = mm.forward_kinematics(model, args.actuators)
    if not found:
        raise AssemblyError(f"actuators {args.actuators} cannot be assembled: forward kinematics has no real solution")
    if args.near is not None:
        check_count(args, args.near, len(names), f"--near ({', '.join(names)})")
        gaps = [_pose_gap(q[-len(names):], args.near, names) for q, _s in found]
        found = [found[int(np.argmin(gaps))]]
        if min(gaps) > NEAR_TOLERANCE:
            _far_from_near(args.near, found[0][0][-len(names):])
    records = []
    for q, s in found:
        pose = q[-len(names):].tolist()
        where = f"the assembly mode at pose ({', '.join(f'{v:.6f}' for v in pose)})"
        _screen_model(where, s, (), "--rates", rates)
        with np.errstate(all="ignore"):
            m_theta, c_theta, g_theta = mm.actuator_space_model(model, q, rates)
        _screen_model(where, s, (m_theta, c_theta, g_theta), "--rates", rates)
        record = {"M": m_theta.tolist(), "c": c_theta.tolist(), "g": g_theta.tolist(), "S": s, "pose": pose}
        warning = _near_singularity(where, s, "M and c")
        if warning:
            record["warning"] = warning
        records.append(record)
    if not args.json:
        for rec in records:
            print(f"assembly mode at {', '.join(f'{k} = {v:+.6f}' for k, v in zip(names, rec['pose'], strict=True))}, "
                  f"S = {rec['S']:+.6f}")
            print("  M (actuator space):")
            for row in rec["M"]:
                print("    " + "  ".join(f"{v:+.6e}" for v in row))
            print("  c = C rates: " + "  ".join(f"{v:+.6e}" for v in rec["c"]))
            print("  g (gravity): " + "  ".join(f"{v:+.6e}" for v in rec["g"]))
    return records[0] if args.near is not None else {"solutions": records}


def cmd_dynamics(args) -> dict:
    from ..kinematics import forward_kinematics

    if args.mechanism is not None:
        return cmd_dynamics_mechanism(args)
    check_count(args, args.actuators, 3, "dynamics of the paper's 3-RRR (theta1 theta2 theta3)")
    args.t1, args.t2, args.t3 = args.actuators
    args.theta_dot = [0.0, 0.0, 0.0] if args.theta_dot is None else args.theta_dot
    check_count(args, args.theta_dot, 3, "--theta-dot")
    if args.near is not None:
        check_count(args, args.near, 3, "--near (x y alpha)")
    model = paper_manipulator(args)
    theta = [args.t1, args.t2, args.t3]
    theta_dot = args.theta_dot
    fk = forward_kinematics(model, theta)
    if len(fk) == 0:
        raise AssemblyError(f"theta = {theta} cannot be assembled: forward kinematics has no real solution")
    chosen = [fk.nearest(args.near)] if args.near else list(fk)
    if args.near and _pose_gap(chosen[0].pose, args.near, ("x", "y", "alpha")) > NEAR_TOLERANCE:
        _far_from_near(args.near, chosen[0].pose)
    records = [_dynamics_record(model, sol.q, theta_dot) for sol in chosen]
    if not args.json:
        for rec in records:
            p = rec["pose"]
            print(f"assembly mode at x = {p['x']:+.6f} m, y = {p['y']:+.6f} m, alpha = {p['alpha']:+.6f} rad, "
                  f"S = {rec['S']:+.6f}")
            print("  M_theta (kg m^2):")
            for row in rec["M_theta"]:
                print("    " + "  ".join(f"{v:+.6e}" for v in row))
            print("  C_theta theta_dot (N m): " + "  ".join(f"{v:+.6e}" for v in rec["c_theta"]))
            print("  lambda at zero torque (N): " + "  ".join(f"{v:+.6e}" for v in rec["lambda"]))
    return records[0] if args.near else {"solutions": records}
