"""``pkmlab export-mjcf``: the machine as a MuJoCo model."""

from __future__ import annotations

from ..errors import InvalidParameterError
from ._common import Staged, check_count, loop_closures, mechanism_of, output_path, paper_manipulator, signs


def cmd_export_mjcf(args) -> dict:
    """``export-mjcf``: the machine as a MuJoCo model (MJCF), at the pose ``--pose`` (its configuration in
    ``--mode``) or at its home configuration (:func:`pkmlab.mujoco_export.home_configuration`)."""
    from .. import mechanism_model as mm
    from .. import mujoco_export as mx
    from ..mechanism_model import MechanismModel

    closures = loop_closures(args, "--closures", args.closures, "--stiff", args.stiff)
    if args.mechanism:
        model = mechanism_of(args)
    else:
        model = MechanismModel.from_3rrr(paper_manipulator(args))
    out = output_path(args.out, "--out", {".xml"})
    q = None
    if args.pose is not None:
        names = model.description.pose_names
        check_count(args, args.pose, len(names), f"--pose ({', '.join(names)})")
        modes = mm.working_modes(model)
        mode = tuple(args.mode) if args.mode is not None else modes[0]
        if mode not in modes:
            raise InvalidParameterError(f"--mode must be one of {', '.join(signs(m) for m in modes)} for a "
                                        f"{model.description.notation}, got {signs(mode)}")
        q = mm.inverse_kinematics(model, args.pose, mode)
    options = {"timestep": args.timestep, "integrator": args.integrator, "closures": closures}
    q = mx.home_configuration(model) if q is None else q
    text = mx.mjcf(model, q, **options)
    with Staged(out) as temps:
        temps[0].write_text(text)
    approximations = [line[5:-4] for line in text.splitlines() if line.startswith("<!-- Principal")]
    if not args.json:
        print(f"wrote {out}: the {model.description.name} ({model.description.notation}) for MuJoCo, keyframe "
              f"\"pkmlab\" at pose {', '.join(f'{v:.6g}' for v in q[-model.description.dof:])}")
        for note in approximations:
            print(f"note: {note}")
    return {"mjcf": str(out), "pose": q[-model.description.dof:].tolist(), "qpos": mx.qpos_from_q(model, q).tolist(),
            "joints": list(mx.joint_names(model)), "approximations": approximations}
