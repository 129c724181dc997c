"""``pkmlab ik`` and ``pkmlab fk``: inverse and forward kinematics at one pose or one set of actuator values, of
every machine through one model type (:func:`pkmlab.load`) and one schema:

* ``ik``: ``{"mechanism", "pose_names", "solutions": [{"mode", "theta", "passive", "S"}, ...]}``, one solution
  per working mode that reaches the pose (``"mode": []`` for a machine of one working mode);
* ``fk``: ``{"mechanism", "pose_names", "solutions": [{"pose", "passive", "S"}, ...]}``, every assembly mode.

No reachable working mode, or no assembly mode: exit code 1 and one line, for every machine.
"""

from __future__ import annotations

from ..errors import AssemblyError
from ._common import check_count, mechanism_name, model_of, shown, signs, table, warn_near_singularity, working_mode


def passive_names(model) -> tuple[str, ...]:
    """The names of the passive joints' coordinates (``model.coordinates`` between the actuators and the pose),
    then of the angles of universal joints that carry the platform
    (:func:`~pkmlab.model.mechanism_model.platform_joint_names`)."""
    from ..model import mechanism_model as mm

    return (*(model.coordinates[c] for c in _passive_columns(model)), *mm.platform_joint_names(model.description))


def _passive_columns(model) -> list[int]:
    """The columns of ``q`` after the actuators that are not controlled coordinates."""
    return [c for c in range(model.n_actuators, len(model.coordinates)) if c not in model.pose_columns]


def passive_of(model, q) -> list[float]:
    """The passive joints' values of the configuration ``q`` (:func:`passive_names`)."""
    import numpy as np

    from ..model import mechanism_model as mm

    q = np.asarray(q, dtype=float)
    extra = mm.platform_joint_angles(model, q) if mm.platform_joint_names(model.description) else []
    return [float(v) for v in (*q[_passive_columns(model)], *extra)]


def heading(args, model, what: str) -> str:
    """The first line of a command's text output: what was computed, for which machine."""
    if getattr(args, "params", None):
        return f"{what} of the 3-RRR of {args.params} ({model.description.notation})"
    return f"{what} of the {model.name} ({model.description.notation})"


def _legs(bits: int) -> list[int]:
    return [i + 1 for i in range(bits.bit_length()) if bits >> i & 1]


def _named(legs: list[int]) -> str:
    words = [str(v) for v in legs]
    return ("leg " if len(words) == 1 else "legs ") + (words[0] if len(words) == 1 else
                                                       ", ".join(words[:-1]) + " and " + words[-1])


def _unreachable(model, pose, mode, ik) -> Exception:
    """The error of a pose that no working mode asked for reaches: which legs cannot, and why the first cannot
    (the library's own words)."""
    import numpy as np

    from ..algorithms.kinematics import inverse_kinematics
    from ..errors import UnreachablePoseError

    masks = [int(m) for m in np.atleast_1d(ik.unreachable_legs)]
    reason = ""
    try:
        inverse_kinematics(model, pose, mode=mode)
    except UnreachablePoseError as exc:
        reason = str(exc)
        prefix = f"pose {np.round(np.asarray(pose, dtype=float), 6).tolist()}: "
        reason = reason[len(prefix):] if reason.startswith(prefix) else reason
    where = f"in working mode {signs(mode)}" if mode is not None else (
        "in its working mode" if len(masks) == 1 else "in every working mode")
    at = ", ".join(f"{n} = {v:g}" for n, v in zip(model.pose_names, pose, strict=True))
    if len(set(masks)) == 1:
        legs = _legs(masks[0])
        who = f"{_named(legs)} cannot reach it"
    else:  # the legs that fail depend on the working mode (a slider's stroke, say)
        legs = _legs(int(np.bitwise_or.reduce(masks)))
        who = f"in each working mode at least one of {_named(legs)} cannot reach it"
    return UnreachablePoseError(f"pose ({at}) is out of reach {where}: {who}" + (f" ({reason})" if reason else ""),
                                legs=tuple(legs))


#: The columns ``--kinds`` adds beside S (the forward measure).
_KIND_COLUMNS = ("inverse", "constraint")


def _add_kinds(model, configurations, solutions) -> None:
    """Each solution's inverse and constraint singularity measures (:func:`pkmlab.singularity_kinds`)."""
    from ..algorithms.singularities import singularity_kinds

    for q, sol in zip(configurations, solutions, strict=True):
        kinds = singularity_kinds(model, q)
        sol["inverse"], sol["constraint"] = float(kinds.inverse), float(kinds.constraint)


def _kind_values(sol) -> list[float]:
    return [sol[k] for k in _KIND_COLUMNS if k in sol]


def cmd_ik(args) -> dict:
    """``ik POSE... [--mode SIGNS] [--mechanism M]``: every working mode that reaches the pose."""
    import numpy as np

    from ..algorithms.kinematics import inverse_kinematics

    model = model_of(args)
    names = model.pose_names
    check_count(args, args.pose, len(names), f"the pose ({', '.join(names)})")
    mode = working_mode(args, model)
    ik = inverse_kinematics(model, args.pose, mode=mode, on_unreachable="nan")
    q = ik.q[None] if mode is not None else ik.q
    modes = ik.modes[None] if mode is not None else ik.modes
    s = np.atleast_1d(ik.S)
    reachable = np.atleast_1d(ik.reachable)
    solutions = [{"mode": [int(v) for v in m], "theta": qi[:model.n_actuators].tolist(),
                  "passive": passive_of(model, qi), "S": float(si)}
                 for m, qi, si, ok in zip(modes, q, s, reachable, strict=True) if ok]
    if not solutions:
        raise _unreachable(model, args.pose, mode, ik)
    if args.kinds:
        _add_kinds(model, [qi for qi, ok in zip(q, reachable, strict=True) if ok], solutions)
    for sol in solutions:  # as dynamics says of its configuration
        warn_near_singularity("ik", f"working mode {signs(sol['mode'])}" if sol["mode"] else "the solution", sol["S"],
                              "its passive joints are nearly undetermined there, and the actuators hold the platform "
                              "poorly")
    if not args.json:
        print(heading(args, model, "inverse kinematics") + " at "
              + ", ".join(f"{n} = {v:g}" for n, v in zip(names, args.pose, strict=True)))
        header = ["mode", *(f"theta{i + 1}" for i in range(model.n_actuators)), *passive_names(model), "S",
                  *_KIND_COLUMNS[:2 * args.kinds]]
        print(table(header, [[signs(sol["mode"]) if sol["mode"] else "-", *sol["theta"], *sol["passive"], sol["S"],
                              *_kind_values(sol)] for sol in solutions]))
    return {"mechanism": mechanism_name(args, model), "pose_names": list(names), "solutions": solutions}


def cmd_fk(args) -> dict:
    """``fk THETA... [--mechanism M]``: every assembly mode of the actuator values."""
    from ..algorithms.kinematics import forward_kinematics

    model = model_of(args)
    check_count(args, args.theta, model.n_actuators, "the actuator values")
    found = forward_kinematics(model, args.theta)
    if len(found) == 0:
        raise AssemblyError(f"theta = {shown(args.theta)} cannot be assembled: forward kinematics of the "
                            f"{model.name} has no real solution")
    solutions = [{"pose": mode.pose.tolist(), "passive": passive_of(model, mode.q), "S": mode.S} for mode in found]
    # a redundantly actuated machine's: how far each actuator's given value is from the configuration found
    # (the actuators found.solved are solved for, the others checked)
    checked = [] if found.solved is None else [i for i in range(model.n_actuators) if i not in found.solved]
    for j, sol in enumerate(solutions):
        if found.residual is not None:
            sol["actuator_residual"] = found.residual[j].tolist()
    if args.kinds:
        _add_kinds(model, [mode.q for mode in found], solutions)
    if not args.json:
        print(heading(args, model, "forward kinematics") + f" at theta = {shown(args.theta)}: "
              f"{len(solutions)} assembly mode(s)")
        rows = [[str(j + 1), *sol["pose"], *sol["passive"], sol["S"],
                 *[sol["actuator_residual"][i] for i in checked], *_kind_values(sol)]
                for j, sol in enumerate(solutions)]
        print(table(["#", *model.pose_names, *passive_names(model), "S", *[f"residual{i + 1}" for i in checked],
                     *_KIND_COLUMNS[:2 * args.kinds]], rows))
        print(f"method: {found.method}")
    return {"mechanism": mechanism_name(args, model), "pose_names": list(model.pose_names), "solutions": solutions,
            "method": found.method}
