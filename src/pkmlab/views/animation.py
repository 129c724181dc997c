"""Animations of recorded runs: the mechanism rebuilt from its actuated angles, drawn frame by frame.

:func:`rebuild_configurations` turns a recorded sequence of actuated angles back into full
configurations — forward kinematics at the first sample (the assembly mode nearest the recorded
pose), then branch following sample by sample (paper §3.2). :func:`write_gif` draws them, with
the desired path and the trail of the centroid, into an animated GIF written atomically.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..errors import AssemblyError, BranchFollowingError, PkmlabError
from ..outputs import atomic_file


def _segments(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the segments start[i]–end[i] as one polyline broken by NaN."""
    pts = np.full((3 * len(start), 2), np.nan)
    pts[0::3], pts[1::3] = start, end
    return pts[:, 0], pts[:, 1]


def _canvas_pillow_writer(fps: int):
    """A :class:`matplotlib.animation.PillowWriter` that takes each frame from the canvas as drawn.

    The stock writer redraws the whole figure per frame (``savefig``); here the caller restores
    the static background and draws only the moving artists (blitting), several times faster,
    and each frame is reduced to a 128-colour palette as it is grabbed.
    """
    from matplotlib.animation import PillowWriter
    from PIL import Image

    class CanvasPillowWriter(PillowWriter):
        def grab_frame(self, **savefig_kwargs):
            canvas = self.fig.canvas
            size = canvas.get_width_height(physical=True)
            frame = Image.frombuffer("RGBA", size, bytes(canvas.buffer_rgba()), "raw", "RGBA", 0, 1)
            # quantised here, fast, rather than by the GIF encoder at the end (slow)
            self._frames.append(frame.convert("RGB").quantize(colors=128, method=Image.Quantize.FASTOCTREE))

    return CanvasPillowWriter(fps=fps)


def write_gif(model, t, q, desired_xy, path: str | os.PathLike, frames: Sequence[int],
              fps: int = 20, title: str = "", dpi: int = 90,
              on_frame: Callable[[], None] | None = None) -> Path:
    """Draw configurations ``q[frames]`` of a planar machine of three-joint legs (the paper's 3-RRR:
    :func:`~pkmlab.views.plotting.three_joint_planar`) into an animated GIF at ``path`` (written atomically).

    Each frame shows the base, the legs (active links bold), the platform, the desired path
    ``desired_xy`` (N, 2) dashed, the trail of the centroid up to that sample and the time
    ``t``. ``on_frame`` is called after each frame (progress). The GIF is written to a temporary
    file beside ``path`` and moved into place only when complete.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    path = Path(path)
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    desired_xy = np.asarray(desired_xy, dtype=float)
    frames = [int(k) for k in frames]
    from ..model.mechanism_model import joint_positions

    points = joint_positions(model, q)
    b, e, p = points[0, :, 0], points[:, :, 1], points[:, :, 2]
    centroid = q[:, -3:-1]

    fig, ax = plt.subplots(figsize=(6.0, 5.6), dpi=dpi, layout="constrained")
    try:
        shown = np.vstack([b, e[frames].reshape(-1, 2), p[frames].reshape(-1, 2), desired_xy, centroid])
        lo, hi = shown.min(axis=0), shown.max(axis=0)
        pad = 0.06 * float(np.max(hi - lo))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.grid(alpha=0.25)
        tri = np.vstack([b, b[:1]])
        ax.plot(tri[:, 0], tri[:, 1], "k--", lw=0.8, label="base")
        ax.plot(b[:, 0], b[:, 1], "ks", ms=6)
        ax.plot(desired_xy[:, 0], desired_xy[:, 1], "--", color="tab:gray", lw=1.2, label="desired path")
        (trail,) = ax.plot([], [], color="tab:red", lw=1.5, label="actual centroid")
        (active,) = ax.plot([], [], color="tab:blue", lw=3, solid_capstyle="round", label="active links")
        (passive,) = ax.plot([], [], color="tab:orange", lw=2, label="passive links")
        (elbows,) = ax.plot([], [], "o", color="tab:blue", ms=4)
        platform = Polygon(p[frames[0]], closed=True, color="tab:green", alpha=0.45, label="platform")
        ax.add_patch(platform)
        (centre,) = ax.plot([], [], "k+", ms=9)
        clock = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9, family="monospace",
                        bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.8})
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(title, fontsize=10)
        fig.legend(loc="outside lower center", ncols=3, fontsize=8, frameon=False)
        fig.canvas.draw()
        fig.set_layout_engine("none")  # freeze the layout: frames must not jitter
        moving = (platform, trail, passive, active, elbows, centre, clock)  # drawn in this order
        for artist in moving:
            artist.set_animated(True)
        fig.canvas.draw()  # everything that does not move, drawn once
        background = fig.canvas.copy_from_bbox(fig.bbox)

        def draw(k: int) -> None:
            active.set_data(*_segments(b, e[k]))
            passive.set_data(*_segments(e[k], p[k]))
            elbows.set_data(e[k, :, 0], e[k, :, 1])
            platform.set_xy(p[k])
            centre.set_data([centroid[k, 0]], [centroid[k, 1]])
            trail.set_data(centroid[: k + 1, 0], centroid[: k + 1, 1])
            clock.set_text(f"t = {t[k]:7.3f} s\nα = {round(q[k, -1], 4) + 0.0:+.4f} rad")
            fig.canvas.restore_region(background)
            for artist in moving:
                ax.draw_artist(artist)

        _write_frames(fig, _canvas_pillow_writer(fps), path, frames, draw, dpi, on_frame)
    finally:
        plt.close(fig)
    return path


def _write_frames(fig, writer, path: Path, frames, draw: Callable[[int], None], dpi: int,
                  on_frame: Callable[[], None] | None) -> None:
    """Draw each of ``frames`` with ``draw(k)`` and grab it with ``writer`` into a GIF written atomically:
    the file appears at ``path`` only after the last frame (a failure leaves no GIF)."""
    with atomic_file(path, mark=True) as tmp:
        writer.setup(fig, str(tmp), dpi=dpi)
        for k in frames:
            draw(k)
            writer.grab_frame()
            if on_frame is not None:
                on_frame()
        writer.finish()


# ------------------------------------------------------------------ any described mechanism
def rebuild_configurations(model, theta, pose0, poses=None) -> np.ndarray:
    """Configurations ``q`` (N, n_coordinates) continuously following recorded actuator values ``theta`` (N, n).

    The first is the assembly mode whose platform pose is nearest ``pose0`` (a six-degree-of-freedom
    platform's: the inverse kinematics of ``pose0``, checked against ``theta[0]``); each next one is on the
    same branch as the previous (:func:`~pkmlab.algorithms.kinematics.branch_following`, paper §3.2). A redundantly
    actuated machine's actuators over-determine its pose, which the run recorded: its configurations are the
    inverse kinematics of the recorded ``poses`` (N, dof) in the working mode whose actuators are ``theta[0]``,
    checked against every sample's ``theta``.

    >>> from pkmlab import inverse_kinematics, load
    >>> model = load("paper")
    >>> poses = [[0.20, 0.21, 0.0], [0.21, 0.21, 0.0], [0.22, 0.20, 0.05]]
    >>> ik = inverse_kinematics(model, poses, mode=(-1, 1, -1))
    >>> q = rebuild_configurations(model, ik.theta, poses[0])
    >>> bool(np.allclose(q, ik.q, atol=1e-9))
    True
    """
    from ..algorithms.assembly import assembly_modes
    from ..algorithms.kinematics import branch_following
    from ..model import mechanism_model as mm

    theta = np.asarray(theta, dtype=float)
    m = model.description
    if m.actuation_redundancy:
        return _configurations_of_poses(model, theta, np.asarray(pose0 if poses is None else poses, dtype=float))
    n = model.n_actuators
    if getattr(m, "spatial", False) and m.platform.kind == "rigid":
        # a six-degree-of-freedom platform: the recorded start pose's inverse kinematics (its one working
        # mode), the recorded actuators checked against it below
        # (of the working mode whose actuators are the recorded ones)
        candidates = []
        for mode in mm.working_modes(model):  # the modes that reach it: a leg's other branch may leave its stroke
            try:
                candidates.append(mm.inverse_kinematics(model, pose0, mode))
            except PkmlabError:
                continue
        if not candidates:
            raise AssemblyError(f"the recorded start pose {np.round(pose0, 6).tolist()} is reached in no working "
                                "mode of this machine: is it the one that produced the run?")
        solutions = [(min(candidates, key=lambda q: float(np.abs(q[:n] - theta[0]).max())), 0.0)]
        if np.abs(solutions[0][0][:n] - theta[0]).max() > 1e-6:
            raise AssemblyError(f"the first sample's actuators {np.round(theta[0], 6).tolist()} do not hold the "
                                "recorded start pose with this machine: is it the one that produced the run?")
    else:
        solutions = assembly_modes(model, theta[0])
    if not solutions:
        raise AssemblyError(f"the first sample's actuators {np.round(theta[0], 6).tolist()} cannot be assembled "
                            "with this machine: is it the one that produced the run?")
    pose0 = np.asarray(pose0, dtype=float)
    q = np.empty((theta.shape[0], len(model.coordinates)))
    q[0] = min((sol for sol, _s in solutions), key=lambda sol: float(np.abs(mm.pose_of(model, sol) - pose0).max()))
    for k in range(1, theta.shape[0]):
        try:
            q[k] = branch_following(model, q[k - 1], theta[k])
        except BranchFollowingError as exc:
            raise BranchFollowingError(f"sample {k + 1}: {exc}") from None
    return q


def _configurations_of_poses(model, theta, poses) -> np.ndarray:
    """:func:`rebuild_configurations` of a redundantly actuated machine: the inverse kinematics of the recorded
    ``poses`` (N, dof), one per sample of ``theta``, in the working mode whose actuators are ``theta[0]`` (chosen at
    the first pose, then followed along the path), every sample's actuators checked against ``theta``."""
    from ..model import mechanism_model as mm
    from ..simulation.result import actuator_errors

    poses = poses.reshape(-1, model.dof)
    if len(poses) != len(theta):
        raise AssemblyError(f"a redundantly actuated machine's run is rebuilt from its recorded poses: "
                            f"{len(theta)} samples of actuators, {len(poses)} poses")

    def apart(q):  # each sample's largest gap between its actuators in q and the recorded ones (NaN: unreached)
        return np.abs(actuator_errors(model, q[:, :model.n_actuators], theta[:len(q)])).max(axis=1)

    gaps = {mode: float(apart(mm.path_inverse_kinematics(model, poses[:1], mode)[0])[0])
            for mode in mm.working_modes(model)}
    mode = min(gaps, key=lambda m: gaps[m] if np.isfinite(gaps[m]) else np.inf)
    if not gaps[mode] <= 1e-6:
        raise AssemblyError(f"the first sample's actuators {np.round(theta[0], 6).tolist()} do not hold the "
                            "recorded start pose with this machine: is it the one that produced the run?")
    q = mm.path_inverse_kinematics(model, poses, mode, follow=True)[0]
    bad = ~(apart(q) <= 1e-6)
    if bad.any():
        k = int(np.argmax(bad))
        raise AssemblyError(f"sample {k + 1}: the recorded actuators do not hold the recorded pose with this "
                            "machine: is it the one that produced the run?")
    return q


def write_machine_gif(model, t, q, desired_xy, path: str | os.PathLike, frames: Sequence[int], fps: int = 20,
                      title: str = "", dpi: int = 90, on_frame: Callable[[], None] | None = None) -> Path:
    """:func:`write_gif` for a described mechanism: each frame draws the machine as it is
    (:func:`~pkmlab.views.plotting.draw_mechanism`), the desired path and the tracked point's trail."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import PillowWriter

    from ..model.mechanism_model import joint_positions, tracked_point
    from .plotting import draw_mechanism

    path = Path(path)
    t, q, desired_xy = (np.asarray(a, dtype=float) for a in (t, q, desired_xy))
    frames = [int(k) for k in frames]
    points = joint_positions(model, q[frames])
    shown = np.vstack([points.reshape(-1, 2), desired_xy])
    lo, hi = shown.min(axis=0), shown.max(axis=0)
    pad = 0.08 * float(np.max(hi - lo))
    fig, ax = plt.subplots(figsize=(6.0, 5.6), dpi=dpi, layout="constrained")

    def draw(k: int) -> None:  # the whole frame anew: a machine's parts differ from one structure to another
        ax.cla()
        ax.plot(desired_xy[:, 0], desired_xy[:, 1], "--", color="tab:gray", lw=1.2, label="desired path")
        ax.plot(*tracked_point(model, q[:k + 1]).T, color="tab:red", lw=1.5, label="actual path")
        draw_mechanism(model, q[k], ax=ax, title=f"{title}\nt = {t[k]:7.3f} s")
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)

    try:
        _write_frames(fig, PillowWriter(fps=fps), path, frames, draw, dpi, on_frame)
    finally:
        plt.close(fig)
    return path


def write_spatial_gif(model, t, q, desired, path: str | os.PathLike, frames: Sequence[int], fps: int = 20,
                      title: str = "", dpi: int = 90, on_frame: Callable[[], None] | None = None) -> Path:
    """:func:`write_machine_gif` for a spatial machine: each frame draws it in 3-D
    (:func:`~pkmlab.views.plotting.draw_spatial_mechanism`) with the desired path (K, 3) and the trail, seen from
    one fixed viewpoint with the whole motion in the box."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import PillowWriter

    from ..model.mechanism_model import joint_positions, pose_of
    from .plotting import draw_spatial_mechanism, equal_box

    path = Path(path)
    t, q, desired = (np.asarray(a, dtype=float) for a in (t, q, desired))
    frames = [int(k) for k in frames]
    points = joint_positions(model, q[frames])
    box = np.vstack([points.reshape(-1, 3), desired, [leg.base for leg in model.description.legs]])
    fig = plt.figure(figsize=(6.0, 5.6), dpi=dpi, layout="constrained")
    ax = fig.add_subplot(projection="3d")

    def draw(k: int) -> None:
        ax.cla()
        ax.plot(*desired.T, "--", color="tab:gray", lw=1.2, label="desired path")
        ax.plot(*pose_of(model, q[:k + 1])[:, :3].T, color="tab:red", lw=1.5, label="actual path")
        draw_spatial_mechanism(model, q[k], ax=ax, title=f"{title}\nt = {t[k]:7.3f} s")
        equal_box(ax, box)

    try:
        _write_frames(fig, PillowWriter(fps=fps), path, frames, draw, dpi, on_frame)
    finally:
        plt.close(fig)
    return path
