"""The interactive view of a closed-loop run: the machine animated in sync with its time series.

One Plotly figure: on the left the machine (in the plane, or in 3-D for a spatial machine) with the
desired path and the tracked point's trail; on the right, sharing the time axis, the path error, the
orientation error (a machine with an orientation), the efforts and ``S``, each with a cursor at the
slider's time. A time slider and a play button move the machine, the trail and the cursors
together (Plotly frames); hovering any curve shows its values.

The view is built from :class:`RunView` — what is drawn, whatever produced it: a
:class:`~pkmlab.simulation.result.SimulationResult` (:meth:`RunView.from_result`) or a result folder's CSV
rebuilt by forward kinematics and branch following (:func:`pkmlab.views.folder.read_result_folder`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .plotting import measure_name

#: At most this many animation frames (evenly spread over the run, the last sample included): the
#: HTML file holds every frame's machine, so its size grows with them.
MAX_FRAMES = 150
#: The colours of the machine's parts (as in the Matplotlib figures).
COLOURS = {"actuated": "#1f77b4", "passive": "#ff7f0e", "platform": "#2ca02c", "base": "#444444",
           "desired": "#7f7f7f", "actual": "#d62728", "cursor": "#d62728"}


@dataclass
class RunView:
    """Everything an interactive view draws of one run.

    ``t`` (N,); ``samples`` the samples the animation shows (:func:`frame_samples`); ``joints`` (len(samples),
    legs, joints per leg, 2 or 3): every joint's position at those samples, the base joint first; ``actuated``
    each leg's actuated joints (:attr:`~pkmlab.description.mechanism.JointChain.actuated_joints`), whose bodies
    are drawn bold; ``leg_joints`` how many joints each leg has; ``rigid`` whether the platform is a body joining
    the legs' last joints; ``desired`` and ``actual`` (N, 2 or 3) the tracked point; ``series`` the time series
    drawn beside it, ``{title: (unit, {name: (N,) values})}``; ``summary`` and ``scenario_text`` for the page.
    """

    name: str
    t: np.ndarray
    samples: np.ndarray
    joints: np.ndarray
    actuated: list[tuple[int, ...]]
    leg_joints: list[int]
    rigid: bool
    desired: np.ndarray
    actual: np.ndarray
    series: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    scenario_text: str = ""
    #: The unit of each of ``summary``'s quantities (:func:`~pkmlab.simulation.result.summary_units`).
    units: dict = field(default_factory=dict)

    @property
    def spatial(self) -> bool:
        return self.joints.shape[-1] == 3

    @classmethod
    def from_run(cls, name: str, model, t, q, pose, pose_d, tau, S, pose_names, summary=None,
                 scenario_text: str = "", frames: int | None = None) -> RunView:
        """The view of a run of ``model`` (a :class:`~pkmlab.model.mechanism_model.MechanismModel`) recorded as
        configurations ``q`` (N, n_coordinates), poses, efforts and ``S``; ``frames`` animation frames at most
        (:data:`MAX_FRAMES`)."""
        from ..model.mechanism_model import joint_positions, tracked_point
        from ..simulation.result import orientation_error, path_error, summary_units

        t, q, pose, pose_d, tau, S = (np.asarray(a, dtype=float) for a in (t, q, pose, pose_d, tau, S))
        description = model.description
        samples = frame_samples(len(t), frames or MAX_FRAMES)
        joints = joint_positions(model, q[samples])
        spatial = joints.shape[-1] == 3
        position = 3 if spatial else 2
        desired, actual = pose_d[:, :position], pose[:, :position]
        parasitic = getattr(description.platform, "parasitic_names", ())
        if parasitic:  # a platform of lower mobility: its point from q (x, y or z may be parasitic), desired or not
            actual = tracked_point(model, q)
            desired = actual.copy()
            for k, c in enumerate("xyz"):
                if c in pose_names:
                    desired[:, k] = pose_d[:, list(pose_names).index(c)]
        series = {"path error": ("m", {"|p - p_d|": path_error(pose, pose_d, pose_names)})}
        orientation = orientation_error(pose, pose_d, pose_names)
        if orientation is not None:
            whole = "roll" in pose_names and "yaw" in pose_names
            label = ("|α - α_d|" if "alpha" in pose_names else "angle of R_dᵀR" if whole
                     else "largest controlled angle error")
            series["orientation error"] = ("rad", {label: orientation})
        kinds = description.actuator_kinds
        unit = "N·m" if all(k == "R" for k in kinds) else "N" if all(k == "P" for k in kinds) else "N·m or N"
        series["efforts"] = (unit, {f"τ{i + 1}": tau[:, i] for i in range(tau.shape[1])})
        measure, symbol = measure_name(description)
        series[measure] = ("", {symbol: S})
        legs = description.legs
        return cls(name, t, samples, joints, [leg.actuated_joints for leg in legs], [len(leg.joints) for leg in legs],
                   description.platform.kind != "point", desired, actual, series,
                   {k: v for k, v in (summary or {}).items() if k != "units"}, scenario_text, summary_units(model))

    @classmethod
    def from_result(cls, result, name: str | None = None, scenario_text: str = "") -> RunView:
        """The view of a :class:`~pkmlab.simulation.result.SimulationResult`."""
        return cls.from_run(name or result.scenario.name, result.scenario.plant_model, result.t, result.q,
                            result.pose, result.pose_d, result.tau, result.S, result.pose_names, result.summary(),
                            scenario_text)


def frame_samples(n: int, frames: int = MAX_FRAMES) -> np.ndarray:
    """The samples the animation shows: evenly spread, first and last included."""
    return np.unique(np.linspace(0, n - 1, min(n, frames)).round().astype(int))


# ------------------------------------------------------------------ the figure
def _nan_joined(parts: list[np.ndarray]) -> np.ndarray:
    """Polylines joined into one, separated by NaN (one Plotly trace for many segments)."""
    if not parts:
        return np.empty((0, 0))
    dim = parts[0].shape[1]
    out = []
    for p in parts:
        out += [p, np.full((1, dim), np.nan)]
    return np.vstack(out)


def machine_lines(view: RunView, j: int) -> dict[str, np.ndarray]:
    """The machine at frame ``j`` (sample ``view.samples[j]``): polylines of the actuated bodies, the passive
    ones, the platform and the tracked point."""
    joints, k = view.joints[j], int(view.samples[j])
    actuated, passive = [], []
    for leg, (moved, count) in enumerate(zip(view.actuated, view.leg_joints, strict=True)):
        pts = joints[leg, :count]
        start = 0  # body k runs from joint k to joint k + 1: each run of actuated or passive bodies is one polyline
        for k in range(1, count):
            if k == count - 1 or (k in moved) != (start in moved):
                (actuated if start in moved else passive).append(pts[start:k + 1])
                start = k
    last = np.array([joints[leg, count - 1] for leg, count in enumerate(view.leg_joints)])
    platform = np.vstack([last, last[:1]]) if view.rigid else last[:0]
    return {"actuated": _nan_joined(actuated), "passive": _nan_joined(passive), "platform": platform,
            "point": view.actual[k:k + 1]}


def _scatter(go, xyz: np.ndarray, spatial: bool, **kw):
    if spatial:
        return go.Scatter3d(x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], **kw)
    return go.Scatter(x=xyz[:, 0], y=xyz[:, 1], **kw)


def machine_traces(go, lines: dict, spatial: bool) -> list:
    """The machine's Plotly traces from :func:`machine_lines`: its actuated bodies (bold), its passive ones,
    the platform (filled in the plane) and the tracked point."""
    width = {"actuated": 9 if spatial else 7, "passive": 5 if spatial else 3, "platform": 6 if spatial else 3}
    traces = []
    for part in ("actuated", "passive", "platform"):
        fill = {"fill": "toself", "fillcolor": "rgba(44,160,44,0.35)"} if part == "platform" and not spatial else {}
        traces.append(_scatter(go, lines[part], spatial, mode="lines+markers",
                               name="platform" if part == "platform" else f"{part} bodies",
                               line={"color": COLOURS[part], "width": width[part]},
                               marker={"size": 3 if spatial else 6, "color": COLOURS[part]}, **fill))
    traces.append(_scatter(go, lines["point"], spatial, mode="markers", name="tracked point",
                           marker={"color": "black", "size": 4 if spatial else 10, "symbol": "cross"}))
    return traces


def run_figure(view: RunView) -> dict:
    """The interactive figure of ``view``: machine, paths, time series with cursors, slider and play button — a
    Plotly figure as a dict (``plotly.graph_objects.Figure(spec)`` makes it an object; ``plotly.io.to_html(spec,
    validate=False)`` a page)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    rows = len(view.series)
    spatial = view.spatial
    specs = [[{"rowspan": rows, "type": "scene" if spatial else "xy"}, {"type": "xy"}]]
    specs += [[None, {"type": "xy"}] for _ in range(rows - 1)]
    titles = [""] + [f"{title} ({unit})" if unit else title for title, (unit, _v) in view.series.items()]
    fig = make_subplots(rows=rows, cols=2, specs=specs, column_widths=[0.5, 0.5], shared_xaxes=True,
                        horizontal_spacing=0.08, vertical_spacing=0.06,
                        subplot_titles=[titles[0]] + titles[1:])
    samples = view.samples
    first = int(samples[0])
    mode_line = {"mode": "lines"}
    # static: the base and the desired path
    bases = view.joints[0, :, 0]
    base_line = np.vstack([bases, bases[:1]]) if spatial else bases
    fig.add_trace(_scatter(go, base_line, spatial, mode="lines+markers" if spatial else "markers", name="base",
                           marker={"color": COLOURS["base"], "size": 4 if spatial else 9, "symbol": "square"},
                           line={"color": COLOURS["base"], "width": 4}), row=1, col=1)
    fig.add_trace(_scatter(go, view.desired, spatial, name="desired path", line={"color": COLOURS["desired"],
                                                                                   "dash": "dash", "width": 2},
                           **mode_line), row=1, col=1)
    # animated: the machine, the trail, the cursors
    machine = machine_traces(go, machine_lines(view, 0), spatial)
    first_machine = len(fig.data)
    for trace in machine:
        fig.add_trace(trace, row=1, col=1)
    fig.add_trace(_scatter(go, view.actual[samples[:1]], spatial, name="actual path (trail)",
                           line={"color": COLOURS["actual"], "width": 2}, **mode_line), row=1, col=1)
    # the frames' order: the bodies, the platform, the trail, the tracked point
    animated = [first_machine, first_machine + 1, first_machine + 2, len(fig.data) - 1, first_machine + 3]
    palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2"]
    bounds = []
    for row, (_title, (unit, curves)) in enumerate(view.series.items(), start=1):
        values = np.concatenate([np.asarray(v, dtype=float) for v in curves.values()])
        finite = values[np.isfinite(values)]
        lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        pad = 0.05 * (hi - lo or abs(hi) or 1.0)
        bounds.append((lo - pad, hi + pad))
        for i, (name, v) in enumerate(curves.items()):
            fig.add_trace(go.Scatter(x=view.t, y=v, mode="lines", name=name,
                                     line={"color": palette[i % len(palette)], "width": 1.6},
                                     hovertemplate=f"{name} = %{{y:.4g}} {unit}<br>t = %{{x:.4f}} s<extra></extra>"),
                          row=row, col=2)
    cursors = []
    for row, (lo, hi) in enumerate(bounds, start=1):
        cursors.append(len(fig.data))
        fig.add_trace(go.Scatter(x=[view.t[first]] * 2, y=[lo, hi], mode="lines", showlegend=False,
                                 hoverinfo="skip", line={"color": COLOURS["cursor"], "width": 1.5, "dash": "dot"}),
                      row=row, col=2)
        fig.update_yaxes(range=[lo, hi], row=row, col=2)
    fig.update_xaxes(title_text="t (s)", row=rows, col=2)
    # the frames: the machine, the trail, the tracked point and the cursors at each shown sample, as plain
    # dicts (Plotly's objects would check each of their thousands of values again, for seconds)
    updated = animated + cursors
    kind = "scatter3d" if spatial else "scatter"

    def points(xyz: np.ndarray) -> dict:
        if not len(xyz):
            return {"type": kind, "x": [], "y": [], **({"z": []} if spatial else {})}
        axes = dict(zip("xyz", xyz.T, strict=False))
        return {"type": kind, **axes}

    figure_frames = []
    for j, k in enumerate(samples):
        k = int(k)
        lines = machine_lines(view, j)
        data = [points(lines[part]) for part in ("actuated", "passive", "platform")]
        # the trail through the samples shown so far (every sample's would make the file grow as frames²)
        data.append(points(view.actual[samples[:j + 1]]))
        data.append(points(lines["point"]))
        data += [{"type": "scatter", "x": [float(view.t[k])] * 2, "y": list(b)} for b in bounds]
        figure_frames.append({"name": f"k{k}", "traces": updated, "data": data})
    step = {"frame": {"duration": 0, "redraw": spatial}, "mode": "immediate", "transition": {"duration": 0}}
    fig.update_layout(
        # the steps' own labels would crowd the rail: only the current value is shown
        sliders=[{"active": 0, "currentvalue": {"prefix": "t = ", "suffix": " s", "font": {"color": "#222"}},
                  "pad": {"t": 30}, "ticklen": 0, "minorticklen": 0,
                  "font": {"color": "rgba(0,0,0,0)"},
                  "steps": [{"args": [[f"k{int(k)}"], step], "label": f"{view.t[int(k)]:.3f}", "method": "animate"}
                            for k in samples]}],
        updatemenus=[{"type": "buttons", "direction": "left", "x": 0.0, "y": 0.0, "xanchor": "right",
                      "yanchor": "top", "pad": {"t": 40, "r": 10},
                      "buttons": [{"label": "▶ play", "method": "animate",
                                   "args": [None, {"frame": {"duration": 40, "redraw": spatial},
                                                   "fromcurrent": True, "transition": {"duration": 0}}]},
                                  {"label": "❚❚ pause", "method": "animate",
                                   "args": [[None], {"frame": {"duration": 0, "redraw": spatial},
                                                     "mode": "immediate"}]}]}],
        height=max(660, 170 * rows + 160), margin={"l": 60, "r": 30, "t": 110, "b": 40},
        title={"text": view.name, "x": 0.01}, hovermode="closest", template="plotly_white",
        legend={"orientation": "h", "x": 0.0, "y": 1.02, "yanchor": "bottom", "font": {"size": 11}})
    box = np.vstack([view.joints.reshape(-1, view.joints.shape[-1]), view.desired])
    lo, hi = np.nanmin(box, axis=0), np.nanmax(box, axis=0)
    pad = 0.06 * float(np.max(hi - lo))
    if spatial:
        fig.update_scenes(aspectmode="data", xaxis={"range": [lo[0] - pad, hi[0] + pad], "title": "x (m)"},
                          yaxis={"range": [lo[1] - pad, hi[1] + pad], "title": "y (m)"},
                          zaxis={"range": [lo[2] - pad, hi[2] + pad], "title": "z (m)"})
    else:
        fig.update_xaxes(range=[lo[0] - pad, hi[0] + pad], title_text="x (m)", row=1, col=1)
        fig.update_yaxes(range=[lo[1] - pad, hi[1] + pad], title_text="y (m)", scaleanchor="x", scaleratio=1,
                         row=1, col=1)
    spec = fig.to_dict()
    spec["frames"] = figure_frames
    return spec
