"""Figures: publication-ready Matplotlib plots of pkmlab results.

Each function draws on a given ``ax`` (or a new figure) and returns the ``Axes``, so users
can combine and restyle them; :func:`save` writes a figure atomically.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .analysis import SingularityMap
from .geometry import Planar3RRR


def _axes(ax):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _fig, ax = plt.subplots(figsize=(6.0, 5.2), layout="constrained")
    return ax


def _sign(m: int) -> str:
    return "+" if m > 0 else "−"


def plot_singularity_map(smap: SingularityMap, ax=None, model: Planar3RRR | None = None,
                         path_xy: np.ndarray | None = None, levels: int = 21):
    """Filled contours of ``S`` with the singular contour ``S = 0`` drawn bold (paper figure 3).

    ``model`` adds the base triangle; ``path_xy`` (N, 2) overlays a desired path.
    """
    ax = _axes(ax)
    finite = smap.S[np.isfinite(smap.S)]
    bound = float(np.max(np.abs(finite))) if finite.size else 1.0
    cs = ax.contourf(smap.x, smap.y, smap.S, levels=np.linspace(-bound, bound, levels), cmap="RdBu_r")
    ax.figure.colorbar(cs, ax=ax, label="singularity measure S")
    if finite.size and finite.min() < 0 < finite.max():
        zero = ax.contour(smap.x, smap.y, smap.S, levels=[0.0], colors="k", linewidths=2.0)
        ax.clabel(zero, fmt={0.0: "S = 0"}, fontsize=8)
    if model is not None:
        b = np.vstack([model.base_points, model.base_points[:1]])
        ax.plot(b[:, 0], b[:, 1], "k--", lw=1.0, label="base")
        ax.plot(model.base_points[:, 0], model.base_points[:, 1], "ko", ms=5)
    if path_xy is not None:
        ax.plot(path_xy[:, 0], path_xy[:, 1], color="tab:green", lw=2.0, label="desired path")
    if model is not None or path_xy is not None:
        ax.legend(loc="upper right", fontsize=8)
    mode = ", ".join(_sign(m) for m in smap.mode)
    ax.set_title(f"Singularity measure S at α = {smap.alpha:g} rad\nworking mode ({mode})", fontsize=11)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    return ax


def save(fig, path: str | os.PathLike, dpi: int = 150) -> Path:
    """Write ``fig`` to ``path`` through a temporary file, so no half-written image is left."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=path.suffix, prefix=".tmp-")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the figure ordinary permissions
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
