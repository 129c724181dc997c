"""The performance tables, written at build time from ``benchmarks/results.json`` (what ``make bench`` wrote last).

A page holding the marker ``<!-- pkmlab:benchmark-tables -->`` gets, in its place, the machine and date of the
measurement and three tables: the timed operations, the first calls (compilation or loading included) and the
other measured figures. The numbers are the file's, never retyped, so the page shows the last ``make bench``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

MARKER = "<!-- pkmlab:benchmark-tables -->"
RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results.json"


def _cell(text) -> str:
    """Text for one cell of a Markdown table: pipes and stars (as in "3-R*RR") read as text."""
    return re.sub(r"\s+", " ", str(text)).strip().replace("|", "\\|").replace("*", "\\*")


def _number(x: float) -> str:
    """Three significant digits, thousands separated, as the benchmark's own table prints them."""
    if isinstance(x, bool) or not isinstance(x, int | float):
        return _cell(x)
    if isinstance(x, int):
        return f"{x:,}"
    if x == 0.0 or not math.isfinite(x):
        return str(x)
    if 1e-3 <= abs(x) < 1e6:
        digits = max(0, 2 - int(math.floor(math.log10(abs(x)))))
        return f"{x:,.{digits}f}"
    return f"{x:.2e}"


def _ratio(row: dict) -> str:
    if row.get("is_baseline_reference"):
        return "reference"
    ratio = row.get("speedup_vs_baseline")
    if ratio is None:
        return ""
    return f"{ratio:.1f}× faster" if ratio >= 1.0 else f"{1.0 / ratio:.1f}× slower"


def benchmark_tables(path: Path = RESULTS) -> str:
    data = json.loads(path.read_text(encoding="utf-8"))
    rows = list(data["results"].values())
    machine = data.get("machine", {})
    lines = [
        f"Measured on {data.get('created', 'an unrecorded date')} ({data.get('mode', '')} run, "
        f"{data.get('total_seconds', 0):.0f} s): {machine.get('cpu_model', 'an unrecorded CPU')}, "
        f"{machine.get('cpus_available', machine.get('cpu_count', '?'))} cores available, "
        f"Python {machine.get('python', '?')}, NumPy {machine.get('numpy', '?')}, Numba {machine.get('numba', '?')}, "
        f"pkmlab {machine.get('pkmlab', '?')}.",
        "",
    ]
    if data.get("baseline_note"):
        lines += [f"*Baseline `fsolve`:* {_cell(data['baseline_note'])}", ""]
    if data.get("dynamics_baseline_note"):
        lines += [f"*Baselines `numpy_dyn_*`:* {_cell(data['dynamics_baseline_note'])}", ""]

    per_op = [r for r in rows if r["kind"] == "per_op"]
    lines += ["## Timed operations", "",
              "Median of the repeats; the rate is its inverse; the last column compares with the baseline "
              "measured in the same run.", "",
              "| benchmark | median | unit | rate | vs baseline |", "| --- | ---: | --- | ---: | ---: |"]
    lines += [f"| {_cell(r['name'])} | {_number(r['median_us_per_op'])} | µs/{r['op']} | "
              f"{r['per_second']:,.0f} {r['op']}s/s | {_ratio(r)} |" for r in per_op]

    first = [r for r in rows if r["kind"] == "first_call"]
    lines += ["", "## First calls", "",
              "One call in a fresh process: what compiling or loading the kernels costs once.", "",
              "| call | time |", "| --- | ---: |"]
    lines += [f"| {_cell(r['name'])} | {_number(r['median_s'] * 1e3)} ms |" for r in first]

    metrics = [r for r in rows if r["kind"] == "metric"]
    lines += ["", "## Other measurements", "", "| measurement | value | unit |", "| --- | ---: | --- |"]
    lines += [f"| {_cell(r['name'])} | {_number(r['value'])} | {_cell(r.get('unit', ''))} |" for r in metrics]

    known = {"per_op", "first_call", "metric"}
    other = sorted({r["kind"] for r in rows} - known)
    if other:  # a new kind of row is a change to this page, not a silent omission
        raise ValueError(f"{path}: rows of kind {', '.join(other)} have no table on the performance page")
    return "\n".join(lines) + "\n"


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, benchmark_tables())


if __name__ == "__main__":
    print(benchmark_tables())
