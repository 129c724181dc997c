"""``pkmlab export-mjcf``: the machine as a MuJoCo model."""

from __future__ import annotations

from ._common import Staged, check_count, loop_closures, mechanism_name, model_of, notes, output_path, working_mode


def cmd_export_mjcf(args) -> dict:
    """``export-mjcf``: the machine as a MuJoCo model (MJCF), at the pose ``--pose`` or at its home configuration
    (:func:`pkmlab.interop.mujoco_export.home_configuration`), in the working mode ``--mode`` (default: the
    first). What the export approximates is said on stderr, as notes."""
    from ..algorithms.kinematics import inverse_kinematics, working_modes
    from ..interop import mujoco_export as mx
    from ..model import mechanism_model as mm

    closures = loop_closures(args, "--closures", args.closures, "--stiff", args.stiff)
    model = model_of(args)
    out = output_path(args.out, "--out", {".xml"}, args.force)
    q = None
    mode = working_mode(args, model)
    if args.pose is not None:
        names = model.pose_names
        check_count(args, args.pose, len(names), f"--pose ({', '.join(names)})")
        mode = tuple(int(s) for s in working_modes(model)[0]) if mode is None else mode
        q = inverse_kinematics(model, args.pose, mode=mode).q
    options = {"timestep": args.timestep, "integrator": args.integrator, "closures": closures}
    q = mx.home_configuration(model, mode) if q is None else q
    text = mx.mjcf(model, q, **options)
    with Staged(out) as temps:
        temps[0].write_text(text)
    approximations = [line[5:-4] for line in text.splitlines() if line.startswith("<!-- Principal")]
    if not args.json:
        print(f"wrote {out}: the {model.description.name} ({model.description.notation}) for MuJoCo, keyframe "
              f"\"pkmlab\" at pose {', '.join(f'{v:.6g}' for v in mm.pose_of(model, q))}")
        say = notes(args)
        for note in approximations:
            say(note)
    return {"mechanism": mechanism_name(args, model), "mjcf": str(out), "pose": mm.pose_of(model, q).tolist(),
            "qpos": mx.qpos_from_q(model, q).tolist(),
            "joints": list(mx.joint_names(model)), "approximations": approximations}
