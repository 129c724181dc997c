"""``pkmlab reproduce`` (the paper's three cases) and ``pkmlab demo`` (its kinematics on the paper's circle)."""

from __future__ import annotations

from pathlib import Path

from .._version import __version__
from ._common import check_resolution, mechanism_name, model_of, notes, signs, status_messages


def cmd_demo(args) -> dict:
    """Kinematics demo on the paper's circle: IK, FK, branch following and figure 3."""
    import matplotlib

    from ..outputs import atomic_output_dir

    matplotlib.use("Agg")

    def say(text: str) -> None:  # progress report, kept off stdout with --json
        if not args.json:
            print(text)

    model = model_of(args)
    from ..algorithms.kinematics import refuse_actuation_redundancy

    refuse_actuation_redundancy(model, "the demo (branch following along the paper's circle)")
    if model.pose_names != ("x", "y", "alpha"):
        from ..errors import InvalidParameterError

        raise InvalidParameterError(f"the demo follows the paper's circle with a planar platform's pose (x, y, "
                                    f"alpha); the {model.name}'s pose is ({', '.join(model.pose_names)})")
    check_resolution(args.resolution)  # refused before anything is computed or printed
    out_dir = Path(args.out)
    given = args.params or args.mechanism
    provenance = {"pkmlab_version": __version__, "resolution": args.resolution,
                  "mechanism": mechanism_name(args, model) if given else "the paper's"}
    inputs = [p for p in (args.params, args.mechanism) if p and Path(p).suffix == ".toml"]
    with atomic_output_dir(out_dir, "demo", inputs=inputs, provenance=provenance, note=notes(args)) as tmp:
        mode = _demo(args, model, say, tmp)
    out = out_dir / "fig03_singularity_map.png"
    say(f"wrote {out}")
    return {"working_mode": list(mode), "figure": str(out)}


def _demo(args, model, say, folder: Path) -> tuple:
    import matplotlib.pyplot as plt
    import numpy as np

    from ..algorithms.analysis import singularity_map
    from ..algorithms.kinematics import branch_following, forward_kinematics, inverse_kinematics
    from ..views.plotting import plot_singularity_map

    start = np.array([0.20, 0.21, 0.0])
    s_path = np.linspace(0.0, 2 * np.pi, 721)
    path = np.stack([0.25 + 0.05 * np.cos(np.pi + s_path), 0.21 + 0.05 * np.sin(np.pi + s_path),
                     np.zeros_like(s_path)], axis=-1)
    ik_path = inverse_kinematics(model, path, on_unreachable="nan")
    min_s = np.nanmin(np.abs(ik_path.S), axis=0)
    best = int(np.nanargmax(min_s))
    mode = tuple(int(m) for m in ik_path.modes[best])
    say("paper circle: min |S| along the path per working mode: "
        + ", ".join(f"{signs(m)} {v:.3f}" for m, v in zip(ik_path.modes, min_s, strict=True)))
    say(f"working mode maximising min |S|: {signs(mode)}")
    ik = inverse_kinematics(model, start, mode=mode)
    fk = forward_kinematics(model, ik.theta)
    say(f"start pose {start.tolist()}: theta = {np.round(ik.theta, 6).tolist()}, "
        f"{len(fk)} assembly modes:")
    n = model.n_actuators
    for j, sol in enumerate(fk):
        say(f"  {j + 1}: x = {sol.pose[0]:+.6f}  y = {sol.pose[1]:+.6f}  alpha = {sol.pose[2]:+.6f}  "
            f"S = {sol.S:+.4f}")
    # Branch following around the circle, driven by the IK of the chosen working mode.
    q = fk.nearest(start).q
    worst = 0.0
    for k in range(1, len(path)):
        q = branch_following(model, q, ik_path.q[k, best, :n])
        worst = max(worst, float(np.max(np.abs(q[n:] - ik_path.q[k, best, n:]))))
    say(f"branch following around the circle: largest deviation from IK passive coordinates {worst:.2e}")
    smap = singularity_map(model, alpha=0.0, mode=mode, resolution=args.resolution)
    ax = plot_singularity_map(smap, model=model, path_xy=path[:, :2])
    try:
        ax.figure.savefig(folder / "fig03_singularity_map.png", dpi=150)
    finally:
        plt.close(ax.figure)
    return mode


def cmd_reproduce(args) -> dict:
    """The paper's three cases: summary.json, CSVs, figures 3-15 and REPORT.md in --out."""
    from ..report import reproduce

    progress = status_messages(args)
    given = args.params or args.mechanism
    source = args.params or (args.mechanism if given and Path(args.mechanism).suffix == ".toml" else None)
    summary = reproduce(args.out, control=args.control, figures=not args.no_figures, progress=progress,
                        mechanism=model_of(args) if given else None, note=notes(args), source=source)
    if not args.json:
        print(f"{'case':<10} {'max path error (m)':>19} {'rms path error (m)':>19} {'peak torque (N m)':>18}")
        for name, s in summary["cases"].items():
            print(f"{name:<10} {s['max_path_error_m']:>19.4e} {s['rms_path_error_m']:>19.4e} "
                  f"{max(s['peak_torque_Nm']):>18.4f}")
        prov = summary["provenance"]
        print(f"results in {args.out}/ ({prov['control']} control, mechanism: {prov['mechanism']})")
    return summary
