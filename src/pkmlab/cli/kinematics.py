"""``pkmlab ik`` and ``pkmlab fk``: inverse and forward kinematics at one pose or one set of actuator values."""

from __future__ import annotations

from ..errors import AssemblyError, InvalidParameterError
from ._common import check_count, mechanism_of, paper_manipulator, signs, table


def cmd_ik_mechanism(args) -> dict:
    """``ik --mechanism M POSE...``: ``{"solutions": [{"mode", "actuators", "S"}, ...]}``, one per working mode
    that reaches the pose (one contract for every machine)."""
    from .. import mechanism_model as mm
    from ..errors import UnreachablePoseError

    model = mechanism_of(args)
    names = model.description.pose_names
    check_count(args, args.pose, len(names), f"the pose ({', '.join(names)})")
    modes = mm.working_modes(model)
    if args.mode is not None:
        if args.mode not in modes:
            raise InvalidParameterError(f"--mode must be one of {', '.join(signs(m) for m in modes)} for a "
                                        f"{model.description.notation}, got {signs(args.mode)}")
        modes = [args.mode]
    solutions, reasons = [], []
    for mode in modes:
        try:
            q = mm.inverse_kinematics(model, args.pose, mode)
        except UnreachablePoseError as exc:
            reasons.append(str(exc))
            continue
        solutions.append({"mode": list(mode), "actuators": q[:model.n_actuators].tolist(),
                          "S": mm.singularity_measure(model, q)})
    if not solutions:
        where = f"in working mode {signs(args.mode)}" if args.mode is not None else "in every working mode"
        raise UnreachablePoseError(f"pose {args.pose} is out of reach {where}: {reasons[0]}")
    if not args.json:
        print(f"inverse kinematics of the {model.description.name} ({model.description.notation}) at "
              + ", ".join(f"{n} = {v:g}" for n, v in zip(names, args.pose, strict=True)))
        header = ["mode", *(f"actuator{i + 1}" for i in range(model.n_actuators)), "S"]
        print(table(header, [[signs(s["mode"]) if s["mode"] else "-", *s["actuators"], s["S"]] for s in solutions]))
    return {"solutions": solutions}


def cmd_fk_mechanism(args) -> dict:
    """``fk --mechanism M ACTUATORS...``: ``{"solutions": [{"pose", "S"}, ...]}``, every assembly mode."""
    from .. import mechanism_model as mm

    model = mechanism_of(args)
    check_count(args, args.actuators, model.n_actuators, "the actuator values")
    found = mm.forward_kinematics(model, args.actuators)
    dof = model.description.dof
    solutions = [{"pose": q[-dof:].tolist(), "S": s} for q, s in found]
    if not args.json:
        print(f"forward kinematics of the {model.description.name} ({model.description.notation}) at actuators "
              f"{' '.join(f'{v:g}' for v in args.actuators)}: {len(solutions)} assembly mode(s)")
        rows = [[str(j + 1), *sol["pose"], sol["S"]] for j, sol in enumerate(solutions)]
        print(table(["#", *model.description.pose_names, "S"], rows))
    return {"solutions": solutions}


def cmd_ik(args) -> dict:
    import numpy as np

    from ..kinematics import inverse_kinematics

    if args.mechanism is not None:
        return cmd_ik_mechanism(args)
    check_count(args, args.pose, 3, "ik of the paper's 3-RRR (x y alpha)")
    args.x, args.y, args.alpha = args.pose
    model = paper_manipulator(args)
    pose = [args.x, args.y, args.alpha]
    ik = inverse_kinematics(model, pose, mode=args.mode)
    q = ik.q[None] if args.mode else ik.q
    modes = ik.modes[None] if args.mode else ik.modes
    svals = np.atleast_1d(ik.S)
    solutions = [
        {"mode": [int(v) for v in m], "theta": qi[:3].tolist(), "phi": qi[3:6].tolist()}
        for m, qi in zip(modes, q, strict=True)
    ]
    if not args.json:
        print(f"inverse kinematics of x = {args.x:g} m, y = {args.y:g} m, alpha = {args.alpha:g} rad")
        rows = [[signs(m), *qi[:6].tolist(), float(s)] for m, qi, s in zip(modes, q, svals, strict=True)]
        print(table(["mode", "theta1", "theta2", "theta3", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}


def cmd_fk(args) -> dict:
    from ..kinematics import forward_kinematics

    if args.mechanism is not None:
        return cmd_fk_mechanism(args)
    check_count(args, args.actuators, 3, "fk of the paper's 3-RRR (theta1 theta2 theta3)")
    args.t1, args.t2, args.t3 = args.actuators
    model = paper_manipulator(args)
    theta = [args.t1, args.t2, args.t3]
    fk = forward_kinematics(model, theta)
    if len(fk) == 0:
        raise AssemblyError(f"theta = {theta} cannot be assembled: forward kinematics has no real solution")
    solutions = [
        {"x": float(s.pose[0]), "y": float(s.pose[1]), "alpha": float(s.pose[2]),
         "phi": s.q[3:6].tolist(), "S": s.S}
        for s in fk
    ]
    if not args.json:
        print(f"forward kinematics of theta = ({args.t1:g}, {args.t2:g}, {args.t3:g}) rad: "
              f"{len(fk)} assembly mode(s)")
        rows = [[str(j + 1), d["x"], d["y"], d["alpha"], *d["phi"], d["S"]] for j, d in enumerate(solutions)]
        print(table(["#", "x", "y", "alpha", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}
