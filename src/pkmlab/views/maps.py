"""Interactive singularity and workspace maps: hover a point for its pose, working mode and ``S``.

``pkmlab singularity-map --out map.html`` and ``pkmlab workspace --out ws.html`` write these instead of
a PNG: one self-contained page (Plotly embedded), a heat map of ``S`` per working mode with the
singular contour ``S = 0`` drawn, the unreachable region left blank.
"""

from __future__ import annotations

import html

import numpy as np

from ..outputs import atomic_file


def _signs(mode) -> str:
    return "(" + ", ".join("+" if m > 0 else "−" for m in mode) + ")" if len(mode) else "(one mode)"


def _heat(go, x, y, S, mode, alpha, bound: float, show_scale: bool):
    where = f"<br>α = {alpha:g} rad" if alpha is not None else ""
    return [go.Heatmap(x=x, y=y, z=S, zmin=-bound, zmax=bound, colorscale="RdBu_r", showscale=show_scale,
                       colorbar={"title": "S"}, hovertemplate="x = %{x:.4f} m<br>y = %{y:.4f} m<br>S = %{z:.4f}<br>"
                       f"working mode {_signs(mode)}{where}<extra></extra>"),
            go.Contour(x=x, y=y, z=S, showscale=False, contours={"start": 0, "end": 0, "size": 1, "coloring": "none"},
                       line={"color": "black", "width": 2.5}, hoverinfo="skip", name="S = 0", showlegend=False)]


def singularity_map_figure(smap) -> dict:
    """The interactive figure of a :class:`~pkmlab.algorithms.analysis.SingularityMap`, as a Plotly dict."""
    import plotly.graph_objects as go

    finite = smap.S[np.isfinite(smap.S)]
    bound = float(np.abs(finite).max()) if finite.size else 1.0
    fig = go.Figure(_heat(go, smap.x, smap.y, smap.S, smap.mode, smap.alpha, bound, True))
    fig.update_layout(title=f"S at α = {smap.alpha:g} rad, working mode {_signs(smap.mode)}; S = 0 in black",
                      template="plotly_white", width=760, height=700)
    fig.update_xaxes(title_text="x (m)")
    fig.update_yaxes(title_text="y (m)", scaleanchor="x", scaleratio=1)
    return fig.to_dict()


def workspace_figure(ws) -> dict:
    """The interactive figure of a planar :class:`~pkmlab.algorithms.analysis.Workspace`: one panel per working mode."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    modes = [tuple(int(v) for v in m) for m in ws.modes]
    cols = min(4, len(modes))
    rows = -(-len(modes) // cols)
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=[f"{_signs(m)}: {a * 1e4:.1f} cm²" for m, a in
                                                              zip(modes, ws.area, strict=True)],
                        horizontal_spacing=0.04, vertical_spacing=0.1)
    finite = ws.S[np.isfinite(ws.S)]
    bound = float(np.abs(finite).max()) if finite.size else 1.0
    for k, mode in enumerate(modes):
        for trace in _heat(go, ws.x, ws.y, ws.S[k], mode, ws.alpha, bound, k == 0):
            fig.add_trace(trace, row=k // cols + 1, col=k % cols + 1)
    fig.update_layout(title=f"reachable workspace at α = {ws.alpha:g} rad, shaded by S; S = 0 in black",
                      template="plotly_white", height=380 * rows + 80, width=330 * cols + 120)
    return fig.to_dict()


def write_map(path, figure: dict, title: str) -> None:
    """A self-contained page of one map, written whole or not at all."""
    import plotly.io as pio

    body = pio.to_html(figure, validate=False, include_plotlyjs=True, full_html=False,
                       config={"displaylogo": False}, div_id="map")
    text = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>"
            f"</head><body style=\"font-family: sans-serif\">{body}</body></html>\n")
    with atomic_file(path, mark=True) as tmp:
        tmp.write_text(text, encoding="utf-8")
