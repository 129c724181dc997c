"""Figures of a study's table: worst-case maps over two axes, distributions under uncertainty, failures.

Each function takes the table (a ``pandas.DataFrame``, one row per run) and returns a Matplotlib
``Figure``, made without pyplot (a notebook's own figures and backend are left alone). The maps show,
per cell of two axes, the worst value over everything else (the other axes and the drawn plants):
what a controller must be designed for. A cell where some run failed is hatched, and says how many.
"""

from __future__ import annotations

import numpy as np

#: The metrics drawn, with their labels.
LABELS = {"max_path_error_m": "max path error (m)", "peak_effort": "peak effort (N·m or N)"}


def _figure(size):
    from matplotlib.figure import Figure

    return Figure(figsize=size, layout="constrained")


def varying_axes(frame, axes: list[str]) -> list[str]:
    """The axes that take more than one value in the table."""
    return [key for key in axes if frame[key].nunique() > 1]


def _label(key: str) -> str:
    return key.split(".")[-1]


def _ticks(values) -> list[str]:
    return [f"{v:.4g}" if isinstance(v, float) else str(v) for v in values]


def _worst(frame, by: list[str], metric: str):
    ok = frame[frame["status"] == "ok"]
    worst = ok.groupby(by, sort=True)[metric].max()
    failed = frame.assign(bad=frame["status"] != "ok").groupby(by, sort=True)["bad"].agg(["sum", "count"])
    return worst, failed


def plot_map(frame, metric: str, x: str, y: str, title: str, label: str | None = None):
    """Heat map of the worst ``metric`` over the cells of axes ``x`` and ``y`` (log colour scale)."""
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Rectangle

    worst, failed = _worst(frame, [y, x], metric)
    xs, ys = sorted(frame[x].unique()), sorted(frame[y].unique())
    grid = np.full((len(ys), len(xs)), np.nan)
    bad = np.zeros((len(ys), len(xs)), dtype=int)
    for (vy, vx), value in worst.items():
        grid[ys.index(vy), xs.index(vx)] = value
    for (vy, vx), (count, _total) in failed.iterrows():
        bad[ys.index(vy), xs.index(vx)] = count
    fig = _figure((1.2 + 0.9 * len(xs) + 1.5, 1.2 + 0.55 * len(ys) + 0.8))
    ax = fig.subplots()
    finite = grid[np.isfinite(grid) & (grid > 0)]
    norm = LogNorm(finite.min(), finite.max()) if finite.size and finite.min() < finite.max() else None
    image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", cmap="viridis", norm=norm)
    fig.colorbar(image, ax=ax, label=f"worst {label or LABELS.get(metric, metric)}")
    light = image.norm(grid) > 0.6  # dark text on the colour map's light end
    for i in range(len(ys)):
        for j in range(len(xs)):
            text = f"{grid[i, j]:.2g}" if np.isfinite(grid[i, j]) else "—"
            if bad[i, j]:
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="//", edgecolor="red", lw=0))
                text += f"\n{bad[i, j]} failed"
            dark = not np.isfinite(grid[i, j]) or bool(light[i, j])
            ax.text(j, i, text, ha="center", va="center", fontsize=7, color="black" if dark else "white")
    ax.set_xticks(range(len(xs)), _ticks(xs), rotation=45 if len(xs) > 6 else 0)
    ax.set_yticks(range(len(ys)), _ticks(ys))
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title, fontsize=10)
    return fig


def plot_line(frame, metric: str, x: str, title: str, label: str | None = None):
    """The worst, median and best ``metric`` against one axis (failed runs marked)."""
    ok = frame[frame["status"] == "ok"]
    stats = ok.groupby(x, sort=True)[metric].agg(["min", "median", "max"])
    fig = _figure((6.0, 4.0))
    ax = fig.subplots()
    xs = stats.index.to_numpy()
    ax.fill_between(xs, stats["min"], stats["max"], alpha=0.25, label="range over the other inputs")
    ax.plot(xs, stats["max"], "o-", label="worst")
    ax.plot(xs, stats["median"], "s--", label="median")
    bad = frame[frame["status"] != "ok"].groupby(x).size()
    for value, count in bad.items():
        ax.axvline(value, color="red", lw=0.8, ls=":")
        ax.annotate(f"{count} failed", (value, 1.0), xycoords=("data", "axes fraction"), fontsize=7, color="red",
                    ha="center", va="bottom")
    ax.set_yscale("log")
    ax.set_xlabel(x)
    ax.set_ylabel(label or LABELS.get(metric, metric))
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    return fig


def plot_distributions(frame, by: str | None, title: str, labels: dict | None = None):
    """Empirical distributions (CDFs) of two metrics (``labels``: {metric: label}, default the max path error and
    the peak effort) over the runs, one curve per value of axis ``by`` (at most eight; one curve for all runs
    without it)."""
    labels = LABELS if labels is None else labels
    from matplotlib.ticker import NullFormatter

    ok = frame[frame["status"] == "ok"]
    fig = _figure((10.0, 4.0))
    axes = fig.subplots(1, 2)
    groups = list(ok.groupby(by, sort=True)) if by is not None and ok[by].nunique() <= 8 else [("all runs", ok)]
    for ax, metric in zip(axes, labels, strict=True):
        for value, part in groups:
            data = np.sort(part[metric].to_numpy())
            if data.size:
                label = f"{_label(by)} = {value:.4g}" if by is not None and value != "all runs" else "all runs"
                ax.step(data, np.arange(1, data.size + 1) / data.size, where="post", label=label)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels of a short log range overlap
        ax.set_xlabel(labels[metric])
        ax.set_ylabel("fraction of runs ≤ value")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return fig


def plot_failures(frame, axes: list[str], title: str):
    """The fraction of runs that failed over two axes (or one), and the count by reason."""
    failed = frame["status"] != "ok"
    fig = _figure((10.0, 4.0))
    ax, bars = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2, 1]})
    if len(axes) >= 2:
        x, y = axes[1], axes[0]
        rate = frame.assign(f=failed).groupby([y, x], sort=True)["f"].mean()
        xs, ys = sorted(frame[x].unique()), sorted(frame[y].unique())
        grid = np.zeros((len(ys), len(xs)))
        for (vy, vx), value in rate.items():
            grid[ys.index(vy), xs.index(vx)] = value
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="Reds", vmin=0.0, vmax=1.0)
        fig.colorbar(image, ax=ax, label="failure rate")
        ax.set_xticks(range(len(xs)), _ticks(xs), rotation=45 if len(xs) > 6 else 0)
        ax.set_yticks(range(len(ys)), _ticks(ys))
        ax.set_xlabel(x)
        ax.set_ylabel(y)
    elif axes:
        rate = frame.assign(f=failed).groupby(axes[0], sort=True)["f"].mean()
        ax.plot(rate.index, rate.to_numpy(), "o-", color="tab:red")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(axes[0])
        ax.set_ylabel("failure rate")
    else:
        ax.text(0.5, 0.5, f"failure rate {failed.mean():.1%}", ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
    reasons = frame.loc[failed, "reason"].value_counts()
    if reasons.empty:
        bars.text(0.5, 0.5, "no run failed", ha="center", va="center", transform=bars.transAxes)
        bars.set_axis_off()
    else:
        bars.barh(reasons.index, reasons.to_numpy(), color="tab:red")
        bars.set_xlabel("failed runs")
        bars.set_title("by reason", fontsize=9)
    fig.suptitle(f"{title}: {int(failed.sum())} of {len(frame)} runs failed", fontsize=10)
    return fig


def study_figures(frame, axes: list[str], name: str, heatmap: tuple[str, str] | None = None,
                  headline=None) -> dict:
    """Every figure of a study: ``{file name: Figure}``. ``heatmap`` names the two axes of the maps (default:
    the first two axes that vary); ``headline`` the two metrics mapped, ``((metric, label, file stem), ...)``
    (default the max path error and the peak effort)."""
    if headline is None:
        headline = (("max_path_error_m", LABELS["max_path_error_m"], "error_map"),
                    ("peak_effort", LABELS["peak_effort"], "effort_map"))
    labels = {metric: label for metric, label, _stem in headline}
    varying = varying_axes(frame, axes)
    pair = list(heatmap) if heatmap else varying[:2]
    figures = {}
    for metric, label, stem in headline:
        if (frame["status"] == "ok").sum() == 0:
            break
        if len(pair) == 2:
            figures[f"{stem}.png"] = plot_map(frame, metric, pair[1], pair[0], f"{name}: worst {label}", label)
        elif len(pair) == 1:
            figures[f"{stem}.png"] = plot_line(frame, metric, pair[0], f"{name}: {label}", label)
    if frame["draw"].nunique() > 1 and (frame["status"] == "ok").any():
        figures["distributions.png"] = plot_distributions(frame, varying[0] if varying else None,
                                                          f"{name}: under uncertainty", labels)
    figures["failures.png"] = plot_failures(frame, pair, name)
    return figures
