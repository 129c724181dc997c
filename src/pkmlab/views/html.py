"""Self-contained HTML pages of runs: ``REPORT.html``, offline, no server.

One page holds Plotly's JavaScript once (embedded, no CDN) and, per run, its summary table, its
interactive figure (:func:`~pkmlab.views.run.run_figure`) and the scenario that produced it.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from ..outputs import atomic_file
from .run import RunView, run_figure

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 1.5em auto; max-width: 1400px;
       color: #222; padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; border-bottom: 1px solid #ddd; }
table.summary { border-collapse: collapse; font-size: 0.9em; margin: 0.5em 0 1em; }
table.summary td, table.summary th { border: 1px solid #ddd; padding: 0.25em 0.7em; text-align: left; }
table.summary th { background: #f5f5f5; font-weight: 600; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
p.note { color: #555; font-size: 0.9em; }
"""


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return ", ".join(_cell(v) for v in value) if value else "—"
    return html.escape(str(value))


def summary_table(summary: dict, units: dict | None = None) -> str:
    """A run's summary as an HTML table (one row per quantity, its unit beside its value: ``units``, a machine's
    :func:`~pkmlab.simulation.result.summary_units`; ``N*m`` written N·m)."""
    units = units or {}

    def unit(key) -> str:
        text = units.get(key, "").replace("*", "·").replace("|", " or ").replace(",", ", ")
        return f" {html.escape(text)}" if text else ""

    rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{_cell(v)}{unit(k)}</td></tr>" for k, v in summary.items())
    return f'<table class="summary">{rows}</table>'


def page(views: list[RunView], title: str, note: str = "") -> str:
    """The HTML text of a page of ``views``."""
    import plotly.io as pio
    from plotly.offline import get_plotlyjs

    parts = [f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>",
             f"<style>{STYLE}</style><script type=\"text/javascript\">{get_plotlyjs()}</script></head><body>",
             f"<h1>{html.escape(title)}</h1>"]
    if note:
        parts.append(f'<p class="note">{html.escape(note)}</p>')
    parts.append('<p class="note">Drag the time slider or press play: the machine, its trail and the cursors of '
                 "the plots move together; hover a curve for its values. This file works offline.</p>")
    for i, view in enumerate(views):
        if len(views) > 1:
            parts.append(f'<h2 id="{html.escape(view.name)}">{html.escape(view.name)}</h2>')
        if view.summary:
            parts.append(summary_table(view.summary, view.units))
        fig = run_figure(view)
        parts.append(pio.to_html(fig, validate=False, include_plotlyjs=False, full_html=False, auto_play=False,
                                 div_id=f"run-{i}", config={"responsive": True, "displaylogo": False}))
        if view.scenario_text:
            parts.append(f"<details><summary>the scenario of this run</summary><pre>"
                         f"{html.escape(view.scenario_text)}</pre></details>")
    parts.append(f"<script type=\"application/json\" id=\"pkmlab-views\">{json.dumps([v.name for v in views])}"
                 "</script></body></html>\n")
    return "\n".join(parts)


def write_html(path, views: list[RunView], title: str, note: str = "") -> Path:
    """Write the page of ``views`` to ``path`` atomically (whole or not at all)."""
    text = page(views, title, note)
    with atomic_file(path, mark=True) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
