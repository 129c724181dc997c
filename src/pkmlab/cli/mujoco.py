"""``pkmlab export-mjcf``: the machine as a MuJoCo model."""

from __future__ import annotations

from ._common import Staged, check_count, loop_closures, mechanism_name, model_of, output_path, working_mode


def cmd_export_mjcf(args) -> dict:
    """``export-mjcf``: the machine as a MuJoCo model (MJCF), at the pose ``--pose`` (its configuration in
    ``--mode``) or at its home configuration (:func:`pkmlab.interop.mujoco_export.home_configuration`)."""
    from ..algorithms.kinematics import inverse_kinematics, working_modes
    from ..interop import mujoco_export as mx

    closures = loop_closures(args, "--closures", args.closures, "--stiff", args.stiff)
    model = model_of(args)
    out = output_path(args.out, "--out", {".xml"})
    q = None
    mode = working_mode(args, model)
    if args.pose is not None:
        names = model.pose_names
        check_count(args, args.pose, len(names), f"--pose ({', '.join(names)})")
        mode = tuple(int(s) for s in working_modes(model)[0]) if mode is None else mode
        q = inverse_kinematics(model, args.pose, mode=mode).q
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
    return {"mechanism": mechanism_name(args, model), "mjcf": str(out), "pose": q[-model.description.dof:].tolist(),
            "qpos": mx.qpos_from_q(model, q).tolist(),
            "joints": list(mx.joint_names(model)), "approximations": approximations}
