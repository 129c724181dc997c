"""pkmlab in Jupyter: rich HTML for its objects, and the interactive views inline.

Models, kinematic solutions, scenarios and results show as tables: :func:`register` gives IPython's HTML
formatter a function per type, by the type's module and name (``import pkmlab`` does it in a running
IPython), so that pkmlab's types know nothing of their display. :func:`show` displays a result's
interactive view (the same as ``REPORT.html``'s, with Plotly's code embedded: it works in a notebook
opened offline), :func:`draw` a machine at one configuration, :func:`plot` a result's figure as a
``plotly`` object to restyle.
"""

from __future__ import annotations

import html

import numpy as np

from .._validate import as_batch

#: Rows of a table of solutions shown at most (a batch shows its first ones and says how many more).
MAX_ROWS = 12


def _f(v, digits: int = 6) -> str:
    if isinstance(v, (float, np.floating)):
        return "NaN" if np.isnan(v) else f"{float(v):.{digits}g}"
    return html.escape(str(v))


def _vector(values, digits: int = 6) -> str:
    return "(" + ", ".join(_f(v, digits) for v in np.ravel(values)) + ")"


def table(title: str, header: list[str], rows: list[list], note: str = "") -> str:
    """A small HTML table with a caption (what every ``_repr_html_`` of pkmlab returns)."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    extra = f"<div style='color:#666;font-size:90%'>{html.escape(note)}</div>" if note else ""
    return (f"<div><b>{html.escape(title)}</b><table style='border-collapse:collapse'><thead><tr>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>{extra}</div>")


def _signs(mode) -> str:
    return "".join("+" if m > 0 else "−" for m in np.ravel(mode))


def mechanism_html(model) -> str:
    """A model (:func:`pkmlab.load`): its legs (joints, base, bodies' masses) and platform."""
    m = model.description
    rows = [[str(i + 1), html.escape(leg.notation), _vector(leg.base, 4),
             ", ".join(_f(b.mass, 4) for b in leg.bodies), "—" if leg.stroke is None else _vector(leg.stroke, 4)]
            for i, leg in enumerate(m.legs)]
    return table(f"{m.name} ({m.notation})", ["leg", "joints", "base (m)", "body masses (kg)", "stroke"], rows,
                 f"pose ({', '.join(m.pose_names)}); platform {m.platform.kind}, mass {_f(m.platform.mass, 4)} kg; "
                 f"gravity {_vector(m.gravity, 4)} m/s²; coordinates q = ({', '.join(model.coordinates)})")


def ik_html(solution) -> str:
    """An inverse-kinematics solution: one row per working mode (a batch: its first pose)."""
    modes = np.asarray(solution.modes)
    per_pose = 1 if modes.ndim == 1 else len(modes)
    q = np.asarray(solution.q).reshape(-1, per_pose, np.shape(solution.q)[-1])
    s = np.asarray(solution.S).reshape(-1, per_pose)
    note = f"a batch of {len(q)} poses: the first shown" if len(q) > 1 else ""
    na = solution.n_actuators
    rows = [[_signs(mode) or "(one mode)", _vector(qi[:na]), _vector(qi[na:]), _f(si)]
            for mode, qi, si in zip(modes.reshape(per_pose, -1), q[0], s[0], strict=True)]
    return table("Inverse kinematics", ["working mode", "θ", "passive joints and pose", "S"], rows, note)


def fk_html(solution) -> str:
    """A forward-kinematics solution: one row per assembly mode."""
    count = np.asarray(solution.count)
    if count.ndim:
        return table("Forward kinematics", ["θ", "assembly modes"], [[str(i), str(int(c))] for i, c in
                                                                     enumerate(count.ravel()[:MAX_ROWS])],
                     f"a batch of {count.size}")
    rows = [[str(j + 1), _vector(solution.pose[j]), _f(solution.S[j])] for j in range(int(count))]
    return table("Forward kinematics: every assembly mode", ["mode", "pose", "S"], rows,
                 "" if rows else "no assembly mode: these actuator values cannot be assembled")


def scenario_html(scenario) -> str:
    """A scenario: its machine, path, controller and options."""
    model = scenario.model
    machine = (f"{model.description.name} ({model.description.notation})" if hasattr(model, "description")
               else "the paper's 3-RRR")
    trajectory = scenario.trajectory
    controller = scenario.controller
    rows = [["machine", html.escape(machine)], ["plant", "the model" if scenario.plant is None else "its own numbers"],
            ["trajectory", f"{html.escape(type(trajectory).__name__)}, {_f(float(trajectory.duration), 4)} s"],
            ["controller", f"{html.escape(controller.kind)}, kp = {_f(controller.kp)}, kv = "
                           f"{_f(controller.velocity_gain)}"],
            ["sample time", "continuous" if scenario.sample_time == 0 else f"{_f(scenario.sample_time * 1e3)} ms"],
            ["working mode", html.escape(str(scenario.working_mode))]]
    return table(f"Scenario {scenario.name}", ["", ""], rows)


def result_html(result) -> str:
    """A run's summary (``pkmlab.plot(result)`` or ``pkmlab.show(result)`` for the interactive view)."""
    rows = [[html.escape(k), _vector(v) if isinstance(v, list) else _f(v)] for k, v in result.summary().items()]
    return table(f"Run of {result.scenario.name}: {len(result.t)} samples over {_f(float(result.t[-1]), 4)} s",
                 ["quantity", "value"], rows, "pkmlab.plot(result) or pkmlab.show(result): the interactive view")


# ------------------------------------------------------------------ interactive, inline
def _check_result(result) -> None:
    from ..errors import InvalidParameterError, shown
    from ..simulation.result import SimulationResult

    if not isinstance(result, SimulationResult):
        raise InvalidParameterError(f"result must be a SimulationResult (what pkmlab.simulate returns), got "
                                    f"{type(result).__name__} {shown(result, 40)}")


def plot(result):
    """The interactive figure of a result: the machine animated beside its time series (``pkmlab.plot``).

    Shown inline by Jupyter. Needs Plotly.

    Parameters
    ----------
    result : SimulationResult
        A run (:func:`~pkmlab.simulate`).

    Returns
    -------
    plotly.graph_objects.Figure

    Raises
    ------
    InvalidParameterError
        If ``result`` is not a :class:`~pkmlab.SimulationResult`.

    Examples
    --------
    >>> import pkmlab
    >>> figure = pkmlab.plot(pkmlab.simulate(pkmlab.paper_scenario("fast")))
    >>> type(figure).__name__, len(figure.frames) > 0
    ('Figure', True)
    """
    _check_result(result)
    import plotly.graph_objects as go

    from .run import RunView, run_figure

    return go.Figure(run_figure(RunView.from_result(result)))


def draw(model, q, title: str | None = None):
    """A machine at one configuration as a Plotly figure (``pkmlab.draw``).

    Its bodies, the platform and the tracked point; hover shows the joints' coordinates. Needs Plotly.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (n,)
        The configuration (rad or m per entry).
    title : str, optional
        The figure's title (default the machine's name and its pose).

    Returns
    -------
    plotly.graph_objects.Figure

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a model, ``q`` does not have ``n`` components, or ``title`` is not text.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> pkmlab.draw(model, q).layout.title.text
    'five_bar at x = 0.000, y = 0.350'
    """
    import plotly.graph_objects as go

    from ..algorithms.kinematics import as_model
    from ..errors import InvalidParameterError, shown
    from ..model.mechanism_model import joint_positions, pose_of, tracked_point
    from .run import RunView, machine_lines, machine_traces

    model = as_model(model)
    q = as_batch("q", q, len(model.coordinates), single=True)[0][0]
    if title is not None and not isinstance(title, str):
        raise InvalidParameterError(f"title must be text or None, got {shown(title, 40)}")
    description = model.description
    joints = joint_positions(model, q[None])
    spatial = joints.shape[-1] == 3
    pose = pose_of(model, q)
    point = tracked_point(model, q)[None, :]
    one = RunView("", np.zeros(1), np.array([0]), joints, [leg.actuated_joints for leg in description.legs],
                  [len(leg.joints) for leg in description.legs], description.platform.kind != "point", point, point)
    fig = go.Figure(machine_traces(go, machine_lines(one, 0), spatial))
    where = ", ".join(f"{n} = {v:.3f}" for n, v in zip(description.pose_names, pose, strict=True))
    fig.update_layout(title=title or f"{description.name} at {where}", template="plotly_white", height=520)
    if not spatial:
        fig.update_yaxes(scaleanchor="x", scaleratio=1)
    return fig


def show(result) -> None:
    """Display a result's interactive view in the notebook (Plotly's code embedded: works offline).

    Needs Plotly and IPython.

    Parameters
    ----------
    result : SimulationResult
        A run (:func:`~pkmlab.simulate`).

    Returns
    -------
    None
        The view is displayed (as HTML), not returned.

    Raises
    ------
    InvalidParameterError
        If ``result`` is not a :class:`~pkmlab.SimulationResult`.

    Examples
    --------
    Outside a notebook, IPython's display prints the object's text:

    >>> import pkmlab
    >>> pkmlab.show(pkmlab.simulate(pkmlab.paper_scenario("fast")))
    <IPython.core.display.HTML object>
    """
    _check_result(result)
    import plotly.io as pio
    from IPython.display import HTML, display

    from .run import RunView, run_figure

    display(HTML(pio.to_html(run_figure(RunView.from_result(result)), validate=False, include_plotlyjs=True,
                             full_html=False, auto_play=False)))


#: The types shown as tables: (module, type name) -> the function that writes the table.
HTML_TABLES = {
    ("pkmlab.model.mechanism_model", "MechanismModel"): mechanism_html,
    ("pkmlab.algorithms.kinematics", "InverseKinematicsSolution"): ik_html,
    ("pkmlab.algorithms.kinematics", "ForwardKinematicsSolution"): fk_html,
    ("pkmlab.simulation.scenario", "Scenario"): scenario_html,
    ("pkmlab.simulation.result", "SimulationResult"): result_html,
}


def register(shell) -> None:
    """Give an IPython ``shell``'s HTML formatter the tables of pkmlab's types (by name: nothing is imported
    until an object of the type is shown)."""
    formatter = shell.display_formatter.formatters["text/html"]
    for (module, name), function in HTML_TABLES.items():
        formatter.for_type_by_name(module, name, function)
