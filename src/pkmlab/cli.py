"""The ``pkmlab`` command line: a thin layer over the library.

Exit codes: 0 success; 1 a problem with the input (unreachable pose, invalid parameter,
unreadable file, ...), reported as one line on stderr (or as ``{"error": ...}`` on stdout
with ``--json``); 2 a malformed command line; 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

from .errors import AssemblyError, PkmlabError


def _model(args):
    from .geometry import Planar3RRR
    from .io import load_manipulator

    return load_manipulator(args.params) if args.params else Planar3RRR.paper()


def _signs(mode) -> str:
    return "(" + ", ".join("+" if m > 0 else "-" for m in mode) + ")"


def _table(header: list[str], rows: list[list]) -> str:
    cells = [header] + [[f"{v:+.6f}" if isinstance(v, float) else str(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells)


def cmd_ik(args) -> dict:
    from .kinematics import inverse_kinematics

    model = _model(args)
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
        rows = [[_signs(m), *qi[:6].tolist(), float(s)] for m, qi, s in zip(modes, q, svals, strict=True)]
        print(_table(["mode", "theta1", "theta2", "theta3", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}


def cmd_fk(args) -> dict:
    from .kinematics import forward_kinematics

    model = _model(args)
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
        print(_table(["#", "x", "y", "alpha", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}


def cmd_demo(args) -> dict:
    """Kinematics demo on the paper's circle: IK, FK, branch following and figure 3."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .analysis import singularity_map
    from .kinematics import branch_following, forward_kinematics, inverse_kinematics
    from .plotting import plot_singularity_map, save

    def say(text: str) -> None:  # progress report, kept off stdout with --json
        if not args.json:
            print(text)

    model = _model(args)
    out_dir = Path(args.out)
    try:  # fail before the computation, not after it
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PkmlabError(f"cannot create output folder {out_dir}: {exc.strerror or exc}") from None
    start = np.array([0.20, 0.21, 0.0])
    s_path = np.linspace(0.0, 2 * np.pi, 721)
    path = np.stack([0.25 + 0.05 * np.cos(np.pi + s_path), 0.21 + 0.05 * np.sin(np.pi + s_path),
                     np.zeros_like(s_path)], axis=-1)
    ik_path = inverse_kinematics(model, path, on_unreachable="nan")
    min_s = np.nanmin(np.abs(ik_path.S), axis=0)
    best = int(np.nanargmax(min_s))
    mode = tuple(int(m) for m in ik_path.modes[best])
    say("paper circle: min |S| along the path per working mode: "
        + ", ".join(f"{_signs(m)} {v:.3f}" for m, v in zip(ik_path.modes, min_s, strict=True)))
    say(f"working mode maximising min |S|: {_signs(mode)}")
    ik = inverse_kinematics(model, start, mode=mode)
    fk = forward_kinematics(model, ik.theta)
    say(f"start pose {start.tolist()}: theta = {np.round(ik.theta, 6).tolist()}, "
        f"{len(fk)} assembly modes:")
    for j, sol in enumerate(fk):
        say(f"  {j + 1}: x = {sol.pose[0]:+.6f}  y = {sol.pose[1]:+.6f}  alpha = {sol.pose[2]:+.6f}  "
            f"S = {sol.S:+.4f}")
    # Branch following around the circle, driven by the IK of the chosen working mode.
    q = fk.nearest(start).q
    worst = 0.0
    for k in range(1, len(path)):
        q = branch_following(model, q, ik_path.q[k, best, :3])
        worst = max(worst, float(np.max(np.abs(q[3:] - ik_path.q[k, best, 3:]))))
    say(f"branch following around the circle: largest deviation from IK passive angles {worst:.2e} rad")
    smap = singularity_map(model, alpha=0.0, mode=mode, resolution=args.resolution)
    ax = plot_singularity_map(smap, model=model, path_xy=path[:, :2])
    out = out_dir / "fig03_singularity_map.png"
    try:
        save(ax.figure, out)
    except OSError as exc:
        raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}") from None
    finally:
        plt.close(ax.figure)
    say(f"wrote {out}")
    return {"working_mode": list(mode), "figure": str(out)}


# argparse reads only "-1" and "-1.5" as negative numbers: "-1e-3", "-1.2E+00" or "-inf" would be
# taken for unknown options and the positional argument reported missing. Widen its matcher (a
# private attribute of the parser) so every negative float is read as a value.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


def _accept_negative_numbers(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    parser._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


def _dynamics_record(model, sol_q, theta_dot) -> dict:
    from . import dynamics
    from .kinematics import coordinate_rates, platform_pose

    q_dot = coordinate_rates(model, sol_q, theta_dot)
    m_theta, c_theta = dynamics.actuator_space_model(model, sol_q, theta_dot)
    _qdd, lam = dynamics.constrained_accelerations(model, sol_q, q_dot, [0.0, 0.0, 0.0])
    x, y, alpha = platform_pose(model, sol_q).tolist()
    return {
        "pose": {"x": x, "y": y, "alpha": alpha},
        "q": sol_q.tolist(),
        "q_dot": q_dot.tolist(),
        "M_theta": m_theta.tolist(),
        "c_theta": c_theta.tolist(),
        "C_theta": dynamics.actuator_space_coriolis_matrix(model, sol_q, theta_dot).tolist(),
        "M": dynamics.mass_matrix(model, sol_q).tolist(),
        "lambda": lam.tolist(),
        "kinetic_energy": float(dynamics.kinetic_energy(model, sol_q, q_dot)),
    }


def cmd_dynamics(args) -> dict:
    from .kinematics import forward_kinematics

    model = _model(args)
    theta = [args.t1, args.t2, args.t3]
    theta_dot = args.theta_dot
    fk = forward_kinematics(model, theta)
    if len(fk) == 0:
        raise AssemblyError(f"theta = {theta} cannot be assembled: forward kinematics has no real solution")
    chosen = [fk.nearest(args.near)] if args.near else list(fk)
    records = [_dynamics_record(model, sol.q, theta_dot) for sol in chosen]
    if not args.json:
        for rec in records:
            p = rec["pose"]
            print(f"assembly mode at x = {p['x']:+.6f} m, y = {p['y']:+.6f} m, alpha = {p['alpha']:+.6f} rad")
            print("  M_theta (kg m^2):")
            for row in rec["M_theta"]:
                print("    " + "  ".join(f"{v:+.6e}" for v in row))
            print("  C_theta theta_dot (N m): " + "  ".join(f"{v:+.6e}" for v in rec["c_theta"]))
            print("  lambda at zero torque (N): " + "  ".join(f"{v:+.6e}" for v in rec["lambda"]))
    return records[0] if args.near else {"solutions": records}


def cmd_reproduce(args) -> dict:
    """The paper's three cases: summary.json, CSVs, figures 3-15 and REPORT.md in --out."""
    from .report import reproduce

    progress = None if args.json or args.quiet else (lambda msg: print(msg, file=sys.stderr))
    summary = reproduce(args.out, control=args.control, figures=not args.no_figures, progress=progress)
    if not args.json:
        print(f"{'case':<10} {'max path error (m)':>19} {'rms path error (m)':>19} {'peak torque (N m)':>18}")
        for name, s in summary["cases"].items():
            print(f"{name:<10} {s['max_path_error_m']:>19.4e} {s['rms_path_error_m']:>19.4e} "
                  f"{max(s['peak_torque_Nm']):>18.4f}")
        print(f"results in {args.out}/")
    return summary


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pkmlab", description="Kinematics, dynamics and control of "
                                     "parallel manipulators (planar 3-RRR). Angles in radians, lengths in metres.")
    _accept_negative_numbers(parser)
    sub = parser.add_subparsers(dest="command", required=True)

    def actuated_angles(p):
        for k in (1, 2, 3):
            p.add_argument(f"t{k}", type=float, metavar=f"T{k}")

    def common(p):
        _accept_negative_numbers(p)
        p.add_argument("--params", metavar="FILE.toml", help="manipulator parameters (default: the paper preset)")
        p.add_argument("--json", action="store_true", help="machine-readable output")

    p = sub.add_parser("ik", help="inverse kinematics: every working mode of a platform pose")
    p.add_argument("x", type=float)
    p.add_argument("y", type=float)
    p.add_argument("alpha", type=float)
    p.add_argument("--mode", nargs=3, metavar=("S1", "S2", "S3"), help="one working mode, e.g. + - +")
    common(p)
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("fk", help="forward kinematics: every assembly mode of actuated angles")
    actuated_angles(p)
    common(p)
    p.set_defaults(func=cmd_fk)

    p = sub.add_parser("dynamics", help="actuator-space and full dynamic model at a state (paper eq. 26, 35)")
    actuated_angles(p)
    p.add_argument("--theta-dot", nargs=3, type=float, metavar=("W1", "W2", "W3"), default=[0.0, 0.0, 0.0],
                   help="actuated rates (rad/s), default 0")
    p.add_argument("--near", nargs=3, type=float, metavar=("X", "Y", "ALPHA"),
                   help="only the assembly mode whose platform pose is nearest to (X, Y, ALPHA)")
    common(p)
    p.set_defaults(func=cmd_dynamics)

    p = sub.add_parser("reproduce", help="the paper's three simulated cases with every figure (paper §5)")
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--control", choices=("sampled", "continuous"), default="sampled",
                   help="sampled-data control at 1 ms (default) or continuous-time")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    common(p)
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser("demo", help="kinematics demo on the paper's circle (figure 3)")
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--resolution", type=int, default=241, help="grid points per axis of the S map")
    common(p)
    p.set_defaults(func=cmd_demo)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        result = args.func(args)
    except PkmlabError as exc:
        if getattr(args, "json", False):
            print(json.dumps({"error": {"type": type(exc).__name__, "message": str(exc)}}))
        else:
            print(f"pkmlab {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"pkmlab {args.command}: interrupted", file=sys.stderr)
        return 130
    if getattr(args, "json", False):
        print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
