"""Figures: publication-ready Matplotlib plots of pkmlab results.

Each function draws on a given ``ax`` (or a new figure) and returns the ``Axes``, so users
can combine and restyle them.
"""

from __future__ import annotations

import numpy as np

from ..algorithms.analysis import SingularityMap, Workspace


def _axes(ax):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _fig, ax = plt.subplots(figsize=(6.0, 5.2), layout="constrained")
    return ax


def _sign(m: int) -> str:
    return "+" if m > 0 else "−"


def _base_points(model) -> np.ndarray:
    """The legs' base points, (n, 2)."""
    return np.array([leg.base for leg in model.description.legs], dtype=float)


def plot_singularity_map(smap: SingularityMap, ax=None, model=None,
                         path_xy: np.ndarray | None = None, levels: int = 21):
    """Filled contours of ``S`` with the singular contour ``S = 0`` drawn bold (paper figure 3).

    ``model`` adds the base triangle; ``path_xy`` (N, 2) overlays a desired path.
    """
    ax = _axes(ax)
    finite = smap.S[np.isfinite(smap.S)]
    bound = float(np.max(np.abs(finite))) if finite.size else 1.0
    # a redundantly actuated machine's map is of its actuation's measure σmin(W), never negative
    actuation = model is not None and getattr(model.description, "actuation_redundancy", 0) > 0
    name = measure_name(model.description if model is not None else None)[0]
    cs = ax.contourf(smap.x, smap.y, smap.S, levels=np.linspace(0.0 if actuation else -bound, bound, levels),
                     cmap="Reds" if actuation else "RdBu_r")
    ax.figure.colorbar(cs, ax=ax, label=name)
    if finite.size and finite.min() < 0 < finite.max():
        zero = ax.contour(smap.x, smap.y, smap.S, levels=[0.0], colors="k", linewidths=2.0)
        ax.clabel(zero, fmt={0.0: "S = 0"}, fontsize=8)
    if model is not None:
        base = _base_points(model)
        b = np.vstack([base, base[:1]])
        ax.plot(b[:, 0], b[:, 1], "k--", lw=1.0, label="base")
        ax.plot(base[:, 0], base[:, 1], "ko", ms=5)
    if path_xy is not None:
        ax.plot(path_xy[:, 0], path_xy[:, 1], color="tab:green", lw=2.0, label="desired path")
    if model is not None or path_xy is not None:
        ax.legend(loc="upper right", fontsize=8)
    mode = ", ".join(_sign(m) for m in smap.mode)
    where = f" at α = {smap.alpha:g} rad" if not (model is not None and getattr(model, "description", None)
                                                   and model.description.dof == 2) else ""
    ax.set_title(f"{name[0].upper()}{name[1:]}{where}\nworking mode ({mode})", fontsize=11)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    return ax


def plot_workspace(ws: Workspace, model=None, fig=None):
    """The reachable region at orientation ``ws.alpha`` for each working mode (8 for the 3-RRR).

    A grid of panels (2×4 for 8 modes), one per mode: the reachable region shaded by the sign of ``S``, its
    boundary, and the curves ``S = 0`` where that mode is singular; titles give the mode's signs
    and the reachable area in cm². ``model`` adds the base triangle. Returns the ``Figure``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if fig is None:
        fig = plt.figure(figsize=(13.0, 7.2), layout="constrained")
    count = len(ws.modes)
    rows = 1 if count <= 2 else 2
    axes = np.atleast_2d(fig.subplots(rows, max(1, -(-count // rows)), sharex=True, sharey=True, squeeze=False))
    colours = {"neg": "#9ecae1", "pos": "#fcae91"}
    for k, ax in enumerate(axes.flat):
        if k >= count:
            ax.set_visible(False)
            continue
        s = ws.S[k]
        finite = s[np.isfinite(s)]
        if finite.size:
            big = float(np.max(np.abs(finite))) + 1.0
            ax.contourf(ws.x, ws.y, s, levels=[-big, 0.0, big], colors=[colours["neg"], colours["pos"]])
            if finite.min() < 0 < finite.max():
                ax.contour(ws.x, ws.y, s, levels=[0.0], colors="k", linewidths=1.4)
        mask = ws.reachable[k].astype(float)
        if 0 < mask.sum() < mask.size:
            ax.contour(ws.x, ws.y, mask, levels=[0.5], colors="0.35", linewidths=0.8)
        if model is not None:
            base = _base_points(model)
            b = np.vstack([base, base[:1]])
            ax.plot(b[:, 0], b[:, 1], "k--", lw=0.8)
            ax.plot(base[:, 0], base[:, 1], "ks", ms=4)
        mode = ", ".join(_sign(m) for m in ws.modes[k])
        ax.set_title(f"mode ({mode}): {ws.area[k] * 1e4:.1f} cm²", fontsize=10)
        ax.set_aspect("equal")
        ax.grid(alpha=0.25)
    for ax in axes[-1]:
        ax.set_xlabel("x (m)")
    for ax in axes[:, 0]:
        ax.set_ylabel("y (m)")
    handles = [Patch(color=colours["pos"], label="reachable, S > 0"),
               Patch(color=colours["neg"], label="reachable, S < 0"),
               Line2D([], [], color="k", lw=1.4, label="S = 0 (singular in this mode)"),
               Line2D([], [], color="0.35", lw=0.8, label="workspace boundary")]
    if model is not None:
        handles.append(Line2D([], [], color="k", ls="--", marker="s", ms=4, lw=0.8, label="base"))
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=9, frameon=False)
    fig.suptitle(f"Reachable workspace at α = {ws.alpha:g} rad for each working mode "
                 f"(grid {ws.x.size} × {ws.y.size})", fontsize=12)
    return fig


# ------------------------------------------------------------------ closed-loop results
def three_joint_planar(model) -> bool:
    """Whether ``model`` is a planar machine of three-joint legs of one actuator each on a rigid platform (the
    paper's 3-RRR and its kin): what :func:`plot_configuration` and :func:`~pkmlab.views.animation.write_gif` draw
    in the paper's style (a leg whose elbow is driven too is drawn by :func:`draw_mechanism`, each link as its
    joint is)."""
    m = model.description
    return not getattr(m, "spatial", False) and m.platform.kind == "rigid" and all(
        len(leg.joints) == 3 and len(leg.actuated_joints) == 1 for leg in m.legs)


def plot_configuration(model, q, ax=None, title: str | None = None):
    """Draw a planar machine of three-joint legs (the paper's 3-RRR) at configuration ``q`` as the paper's
    figure 4 does: base triangle, actuated links bold, passive links, platform, centroid; any other machine
    as :func:`draw_mechanism` draws it."""
    from ..model import mechanism_model as mm

    if not three_joint_planar(model):
        return draw_mechanism(model, q, ax=ax, title=title)
    ax = _axes(ax)
    q = np.asarray(q, dtype=float)
    points = mm.joint_positions(model, q)
    b, e, p = points[:, 0], points[:, 1], points[:, 2]
    tri = np.vstack([b, b[:1]])
    ax.plot(tri[:, 0], tri[:, 1], "k--", lw=0.8, label="base")
    for i in range(len(b)):
        ax.plot([b[i, 0], e[i, 0]], [b[i, 1], e[i, 1]], color="tab:blue", lw=3,
                label="active links" if i == 0 else None)
        ax.plot([e[i, 0], p[i, 0]], [e[i, 1], p[i, 1]], color="tab:orange", lw=2,
                label="passive links" if i == 0 else None)
        ax.annotate(f"b{i + 1}", b[i], textcoords="offset points", xytext=(-12, -12), fontsize=8)
        ax.annotate(f"p{i + 1}", p[i], textcoords="offset points", xytext=(4, 4), fontsize=8)
    plat = np.vstack([p, p[:1]])
    ax.fill(plat[:, 0], plat[:, 1], color="tab:green", alpha=0.4, label="platform")
    ax.plot(b[:, 0], b[:, 1], "ks", ms=7)
    ax.plot(e[:, 0], e[:, 1], "o", color="tab:blue", ms=5)
    x, y, alpha = q[-3:]
    ax.plot(x, y, "k+", ms=10)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title or f"configuration at x = {x:.3f} m, y = {y:.3f} m, α = {alpha:.3f} rad")
    return ax


def draw_mechanism(model, q, ax=None, title: str | None = None):
    """Draw a described mechanism (:class:`~pkmlab.model.mechanism_model.MechanismModel`) at configuration ``q``
    as it is: base pivots, each leg through its joints (actuated body bold; a prismatic actuator's rail
    over its stroke with the slider on it, a telescopic leg's cylinder and rod), the platform and the
    tracked point. The joint positions come from the structure's generated ``joint_points``."""
    from ..model import mechanism_model as mm

    ax = _axes(ax)
    q = np.asarray(q, dtype=float)
    m = model.description
    points = mm.joint_positions(model, q)
    once = _legend_once()
    for i, leg in enumerate(m.legs):
        pts = points[i, :len(leg.joints)]
        if leg.joints[0].kind == "P":  # a rail from its base point along its axis, over the stroke
            u = np.array([np.cos(leg.joints[0].axis), np.sin(leg.joints[0].axis)])
            # the rail over the slider's stroke (a kinematically redundant leg's stroke is its ordinary part's)
            lo, hi = (leg.stroke if leg.stroke is not None and leg.actuated == 0
                      else (0.0, float(np.hypot(*(pts[1] - pts[0])))))
            rail = np.array([pts[0] + lo * u, pts[0] + hi * u])
            ax.plot(rail[:, 0], rail[:, 1], color="0.5", lw=4, alpha=0.5, solid_capstyle="butt",
                    label=once("rails"))
            ax.plot(*pts[1], "s", color="tab:blue", ms=9,
                    label=once("actuated sliders" if leg.joints[0].actuated else "sliders"))
            _links(ax, leg, pts, 1, once)
        elif leg.joints[1].kind == "P":  # telescopic: the cylinder from the base, the rod to the platform
            end = pts[-1]
            along = end - pts[0]
            reach = float(np.hypot(*along))
            sleeve = pts[0] + along / reach * min(reach, 2 * abs(leg.bodies[0].com[0]) or 0.5 * reach)
            ax.plot([pts[0, 0], sleeve[0]], [pts[0, 1], sleeve[1]], color="tab:blue", lw=6, alpha=0.7,
                    solid_capstyle="butt", label=once("cylinders"))
            ax.plot([pts[0, 0], end[0]], [pts[0, 1], end[1]], color="tab:orange", lw=2,
                    label=once("actuated rods" if leg.joints[1].actuated else "rods"))
        else:  # R*RR (R*R*RR, R*R*R, …)
            _links(ax, leg, pts, 0, once)
            ax.plot(*pts[1], "o", color="tab:blue", ms=5)
        ax.plot(*pts[0], "ks", ms=7, label=once("base"))
        ax.annotate(f"{i + 1}", pts[0], textcoords="offset points", xytext=(-10, -12), fontsize=8)
    pose = mm.pose_of(model, q)
    if m.platform.kind == "rigid":
        plat = np.vstack([points[:, -1], points[:1, -1]])
        ax.fill(plat[:, 0], plat[:, 1], color="tab:green", alpha=0.4, label="platform")
    ax.plot(pose[0], pose[1], "k+", ms=10, mew=1.5, label="tracked point")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=7)
    where = ", ".join(f"{n} = {v:.3f}" for n, v in zip(m.pose_names, pose, strict=True))
    gap = "\n" if m.redundancy_names else " "  # a kinematically redundant machine's coordinates: a line of theirs
    ax.set_title(title or f"{m.name} ({m.notation}){gap}at {where}")
    return ax


def _legend_once():
    """A legend's labeller: ``once(name)`` is ``name`` the first time, None after (each name once, from whichever
    leg first draws it)."""
    given: set[str] = set()

    def once(name: str) -> str | None:
        if name in given:
            return None
        given.add(name)
        return name

    return once


def _links(ax, leg, pts, start: int, once, width: float = 3.0, noun: str = "links") -> None:
    """A leg's links (bodies) from joint ``start`` on, each bold where its joint is actuated; ``once(name)`` gives
    the legend's label (None where it was given already)."""
    for k in range(start, len(leg.joints) - 1):
        actuated = leg.joints[k].actuated
        ax.plot(*pts[k:k + 2].T, color="tab:blue" if actuated else "tab:orange", lw=width if actuated else 2,
                label=once(f"actuated {noun}" if actuated else f"passive {noun}"))


def _axes3d(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        ax = plt.figure(figsize=(6.0, 5.6), layout="constrained").add_subplot(projection="3d")
    if getattr(ax, "name", "") != "3d":
        raise ValueError("a spatial machine is drawn on 3-D axes: fig.add_subplot(projection='3d')")
    return ax


def equal_box(ax, points: np.ndarray) -> None:
    """Equal scales on the three axes around ``points`` (K, 3)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-3) * 1.05
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))


def draw_spatial_mechanism(model, q, ax=None, title: str | None = None):
    """Draw a spatial mechanism at configuration ``q`` on 3-D axes: base (its legs' base points joined),
    each leg through its joints (the actuated body bold), the platform and the tracked point."""
    from ..model import mechanism_model as mm

    ax = _axes3d(ax)
    q = np.asarray(q, dtype=float)
    m = model.description
    points = mm.joint_positions(model, q)
    base = np.array([leg.base for leg in m.legs] + [m.legs[0].base])
    ax.plot(*base.T, color="0.3", lw=2.5, label="base")
    once = _legend_once()
    for i, leg in enumerate(m.legs):
        pts = points[i, :len(leg.joints)]
        _links(ax, leg, pts, 0, once, width=4.0, noun="bodies")
        ax.scatter(*pts[1:-1].T, color="k", s=8)
    plat = np.vstack([points[:, -1], points[:1, -1]])
    ax.plot(*plat.T, color="tab:green", lw=2.5, label="platform")
    pose = mm.pose_of(model, q)
    ax.scatter(*mm.tracked_point(model, q), color="k", marker="+", s=60, label="tracked point")
    equal_box(ax, np.vstack([points.reshape(-1, 3), base]))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend(loc="upper left", fontsize=7)
    where = ", ".join(f"{n} = {v:.3f}" for n, v in zip(m.pose_names, pose, strict=True))
    ax.set_title(title or f"{m.name} ({m.notation}) at {where}", fontsize=9)
    return ax


def plot_path_3d(result, ax=None):
    """The path of the pose's first three controlled coordinates, tracked vs desired: the tracked point's, or a
    platform of lower mobility's (a 3-PRS's z, roll and pitch, a wrist's roll, pitch and yaw, each axis labelled
    with its unit)."""
    ax = _axes3d(ax)
    d, p = result.pose_d[:, :3], result.pose[:, :3]
    ax.plot(*d.T, "k--", lw=1.5, label="desired")
    ax.plot(*p.T, color="tab:red", lw=1.2, label="tracked")
    ax.scatter(*d[0], color="k", s=15, label="start")
    equal_box(ax, np.vstack([d, p]))
    names = result.pose_names[:3]
    for set_label, name in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), names, strict=True):
        set_label(f"{name} ({'rad' if name in ('roll', 'pitch', 'yaw') else 'm'})")
    ax.legend(fontsize=8)
    ax.set_title(f"path tracked vs desired ({_case(result)})")
    return ax


def plot_start_configuration(result, ax=None):
    """The plant at the start of the run, drawn as it is (:func:`draw_mechanism`, :func:`draw_spatial_mechanism`,
    for a spatial machine)."""
    plant = result.scenario.plant_model
    draw = draw_spatial_mechanism if getattr(plant.description, "spatial", False) else draw_mechanism
    return draw(plant, result.q[0], ax=ax, title=f"the machine at the start ({_case(result)})")


def _case(result) -> str:
    return result.scenario.name


def plot_path(result, ax=None):
    """Platform centroid path tracked vs desired (paper figures 6, 10, 13)."""
    ax = _axes(ax)
    ax.plot(result.pose_d[:, 0], result.pose_d[:, 1], "k--", lw=1.5, label="desired")
    ax.plot(result.pose[:, 0], result.pose[:, 1], color="tab:red", lw=1.2, label="tracked")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8)
    ax.set_title(f"path tracked vs desired ({_case(result)})")
    return ax


def plot_path_error(result, ax=None):
    """Euclidean distance between actual and desired centroid vs time (paper figures 7, 11, 14)."""
    ax = _axes(ax)
    ax.plot(result.t, result.path_error * 1e3, color="tab:red")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("path error (mm)")
    ax.set_title(f"error in path tracking ({_case(result)})")
    ax.grid(alpha=0.3)
    return ax


def plot_alpha(result, ax=None):
    """Platform orientation α vs time, actual and desired (paper figure 8)."""
    ax = _axes(ax)
    ax.plot(result.t, result.pose_d[:, 2], "k--", label="desired α")
    ax.plot(result.t, result.pose[:, 2], color="tab:purple", label="actual α")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("α (rad)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(f"platform orientation ({_case(result)})")
    return ax


def plot_efforts(result, ax=None):
    """Actuator efforts vs time (paper figures 9, 12, 15): torques in N·m, forces (prismatic actuators) in N."""
    ax = _axes(ax)
    from ..simulation.result import actuator_kinds

    kinds = actuator_kinds(result.scenario.plant_model)
    for i in range(result.tau.shape[1]):  # line styles apart, so that equal efforts (a symmetric path) both show
        ax.plot(result.t, result.tau[:, i], ls=("-", "--", "-.", ":")[i % 4], label=f"τ{i + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel({"R": "torque (N·m)", "P": "force (N)"}.get("".join(sorted(kinds)), "effort (N·m, N)"))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(f"actuator {'torques' if kinds == {'R'} else 'efforts'} ({_case(result)})")
    return ax


def measure_name(description) -> tuple[str, str]:
    """The name and symbol of the singularity measure a machine's results and maps show: ``S``, or for a
    redundantly actuated machine its actuation's measure ``σmin(W)``."""
    if getattr(description, "actuation_redundancy", 0) > 0:
        return "actuation measure σmin(W)", "σmin(W)"
    return "singularity measure S", "S"


def plot_singularity_along_path(result, ax=None):
    """``S`` of the plant's configuration along the run (paper figure 5); a redundantly actuated machine's
    actuation measure."""
    ax = _axes(ax)
    name, symbol = measure_name(result.scenario.model.description)
    ax.plot(result.t, result.S, color="tab:blue")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(name)
    ax.set_ylim(min(0.0, float(result.S.min()) * 1.1), max(0.0, float(result.S.max()) * 1.1))
    ax.grid(alpha=0.3)
    ax.set_title(f"{symbol} along the trajectory ({_case(result)})")
    return ax


def plot_spatial_workspace(ws, model=None, fig=None):
    """A spatial machine's workspace in horizontal slices (:func:`~pkmlab.algorithms.analysis.spatial_workspace`): each
    panel shades ``S`` over the reachable region of one height (grey outside) and draws ``S = 0``, where the
    slice cuts the singular surface, in black."""
    import matplotlib.pyplot as plt

    count = len(ws.z)
    cols = min(3, count)
    rows = -(-count // cols)
    if fig is None:
        fig = plt.figure(figsize=(4.2 * cols, 3.9 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    finite = ws.S[np.isfinite(ws.S)]
    bound = float(np.abs(finite).max()) if finite.size else 1.0
    image = None
    for k, ax in enumerate(axes.ravel()):
        if k >= count:
            ax.set_axis_off()
            continue
        extent = (ws.x[0], ws.x[-1], ws.y[0], ws.y[-1])
        ax.imshow(~ws.reachable[k], extent=extent, origin="lower", cmap="Greys", vmin=0, vmax=4, aspect="equal")
        image = ax.imshow(np.ma.masked_invalid(ws.S[k]), extent=extent, origin="lower", cmap="RdBu",
                          vmin=-bound, vmax=bound, aspect="equal")
        s = np.where(np.isfinite(ws.S[k]), ws.S[k], np.nan)
        if np.nanmin(s, initial=np.inf) < 0 < np.nanmax(s, initial=-np.inf):
            ax.contour(ws.x, ws.y, s, levels=[0.0], colors="k", linewidths=1.2)
        ax.set_title(f"z = {ws.z[k]:.3f} m, reachable {ws.area[k] * 1e4:.0f} cm²", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    if image is not None:
        fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.8, label="singularity measure S")
    name = f"{model.description.name} " if model is not None else ""
    mode = "".join("+" if v > 0 else "-" for v in ws.mode) or "its one mode"
    fig.suptitle(f"{name}workspace in horizontal slices, working mode {mode} (S = 0 in black)")
    return fig


def plot_effort_prediction(t, measured, predicted, ax=None, kinds=None):
    """Measured efforts (N, n) against those an identified model predicts at the same states, one colour per
    actuator, on a log the identification did not see: the report of :func:`pkmlab.identify`'s validation."""
    import matplotlib.pyplot as plt

    if ax is None:
        _fig, ax = plt.subplots(figsize=(7.0, 3.6))
    measured, predicted = np.asarray(measured), np.asarray(predicted)
    for j in range(measured.shape[1]):
        line, = ax.plot(t, measured[:, j], lw=1.0, label=f"tau{j + 1} measured")
        ax.plot(t, predicted[:, j], lw=1.0, ls="--", color=line.get_color(), label=f"tau{j + 1} predicted")
    unit = "N m" if kinds is None or set(kinds) == {"R"} else ("N" if set(kinds) == {"P"} else "N m or N")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"effort ({unit})")
    rms = np.sqrt(np.mean((measured - predicted) ** 2, axis=0))
    ax.set_title("held-out efforts: measured and predicted (RMS error " + ", ".join(f"{v:.3g}" for v in rms) + ")",
                 fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return ax


def plot_calibration_validation(before, after, ax=None, unit="m", noise=None):
    """The error at each held-out pose (N,) with the described and with the calibrated geometry, on a log scale,
    and the instrument's noise if given: the report of :func:`pkmlab.algorithms.calibration.calibrate`'s
    validation."""
    import matplotlib.pyplot as plt

    if ax is None:
        _fig, ax = plt.subplots(figsize=(7.0, 3.6))
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    poses = np.arange(1, len(before) + 1)
    ax.semilogy(poses, before, "o", ms=4, label=f"described (worst {before.max():.3g} {unit})")
    ax.semilogy(poses, after, "s", ms=4, label=f"calibrated (worst {after.max():.3g} {unit})")
    if noise is not None:
        ax.axhline(noise, color="0.4", lw=1.0, ls=":", label=f"measurement noise {noise:.3g} {unit}")
    ax.set_xlabel("held-out pose")
    ax.set_ylabel(f"error ({unit})")
    ax.set_title("held-out poses: measured against predicted from the readings", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    return ax
