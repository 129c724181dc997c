"""``pkmlab singularity-map`` and ``pkmlab workspace``: S and the reachable region over a grid of poses."""

from __future__ import annotations

from pathlib import Path

from ..errors import InvalidParameterError, PkmlabError
from ._common import (
    Staged,
    check_resolution,
    figure_suffixes,
    mechanism_name,
    model_of,
    output_path,
    progress_bar,
    save_figure,
    signs,
    table,
    working_mode,
)


def _at_alpha(model, alpha: float) -> str:
    """`` at alpha = A rad`` for a platform that has an orientation alpha (a point's map has none)."""
    return f" at alpha = {alpha:g} rad" if "alpha" in model.pose_names else ""


def _alpha(args, model) -> float:
    """The orientation ``--alpha`` asks for (default 0): refused for a platform without one (a point's)."""
    if args.alpha is None:
        return 0.0
    if "alpha" not in model.pose_names:
        raise InvalidParameterError(f"--alpha: the {model.name}'s platform has no orientation (its pose is "
                                    f"{', '.join(model.pose_names)}): leave --alpha out")
    return args.alpha


def _nothing_reachable(model, x, y, alpha: float) -> PkmlabError:
    return PkmlabError(f"no pose of the region x = {x[0]:g}..{x[-1]:g} m, y = {y[0]:g}..{y[-1]:g} m is reachable"
                       f"{_at_alpha(model, alpha)}: nothing to draw")


def cmd_singularity_map(args) -> dict:
    """S over x-y at one orientation and working mode (paper figure 3), with the singular contour S = 0."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..algorithms.analysis import singularity_map
    from ..views.plotting import plot_singularity_map

    model = model_of(args)
    if getattr(model.description, "spatial", False):
        raise InvalidParameterError(f"singularity-map draws a planar machine's S over x-y; the "
                                    f"{model.description.name} is spatial: `pkmlab workspace --mechanism ... --z Z...` "
                                    "draws its S and S = 0 in horizontal slices")
    mode = working_mode(args, model)
    out = output_path(args.out, "--out", figure_suffixes() | {".html"}, args.force)
    csv_path = output_path(args.csv, "--csv", {".csv"}, args.force) if args.csv else None
    resolution = check_resolution(args.resolution)
    with progress_bar(args, resolution, "singularity map") as bar:
        smap = singularity_map(model, _alpha(args, model), mode, args.x_range, args.y_range, resolution,
                               progress=bar.update)
    reachable = smap.reachable
    if not reachable.any():
        raise _nothing_reachable(model, smap.x, smap.y, smap.alpha)
    finite = smap.S[reachable]
    result = {"mechanism": mechanism_name(args, model), "alpha": smap.alpha, "mode": list(smap.mode),
              "min_S": float(finite.min()), "max_S": float(finite.max()), "reachable_fraction": float(reachable.mean()),
              "figure": str(out), "csv": str(csv_path) if csv_path else None}
    ax = plot_singularity_map(smap, model=model)
    try:
        with Staged(out, *([csv_path] if csv_path else [])) as temps:
            if out.suffix.lower() == ".html":  # interactive: hover shows the pose, the working mode and S
                from ..views.maps import singularity_map_figure, write_map

                write_map(temps[0], singularity_map_figure(smap), f"S{_at_alpha(model, smap.alpha)}")
            else:
                ax.figure.savefig(temps[0], dpi=150)
            if csv_path:
                xx, yy = np.meshgrid(smap.x, smap.y)
                buf = io.StringIO()
                np.savetxt(buf, np.column_stack([xx.ravel(), yy.ravel(), smap.S.ravel()]), fmt="%.17g",
                           delimiter=",", header="x,y,S", comments="")
                temps[1].write_text(buf.getvalue())
    finally:
        plt.close(ax.figure)
    if not args.json:
        print(f"S of the {model.name} ({model.description.notation}){_at_alpha(model, smap.alpha)}, working mode "
              f"{signs(smap.mode) if smap.mode else '-'}, {resolution} x {resolution} grid: "
              f"min S = {result['min_S']:+.4f}, max S = {result['max_S']:+.4f}, "
              f"reachable {100 * result['reachable_fraction']:.1f} % of the grid")
        print(f"wrote {out}" + (f" and {csv_path}" if csv_path else ""))
    return result


def cmd_workspace(args) -> dict:
    """The reachable region at one orientation for each of the 8 working modes, with their S = 0 curves."""
    import matplotlib

    matplotlib.use("Agg")

    from ..algorithms.analysis import workspace
    from ..views.plotting import plot_workspace

    model = model_of(args)
    out = output_path(args.out, "--out", figure_suffixes() | {".html"}, args.force)
    if getattr(model.description, "spatial", False):
        if out.suffix.lower() == ".html":
            raise InvalidParameterError("--out: a spatial machine's slices are drawn as an image (PNG, SVG, PDF); "
                                        "the interactive .html map is a planar machine's")
        return _spatial_workspace(args, model, out)
    if args.z is not None or args.mode is not None:
        raise InvalidParameterError("--z and --mode are for a spatial machine's slices; a planar machine's workspace "
                                    "shows every working mode at one --alpha")
    resolution = check_resolution(args.resolution)
    with progress_bar(args, resolution, "workspace") as bar:
        ws = workspace(model, _alpha(args, model), resolution, args.x_range, args.y_range, progress=bar.update)
    if not ws.reachable.any():
        raise _nothing_reachable(model, ws.x, ws.y, ws.alpha)
    fig = plot_workspace(ws, model=model)
    if out.suffix.lower() == ".html":  # interactive: hover shows the pose, the working mode and S
        import matplotlib.pyplot as plt

        from ..views.maps import workspace_figure, write_map

        plt.close(fig)
        with Staged(out) as temps:
            write_map(temps[0], workspace_figure(ws), f"workspace{_at_alpha(model, ws.alpha)}")
    else:
        save_figure(fig, out)
    areas = [{"mode": [int(v) for v in m], "area_m2": float(a), "area_cm2": float(a) * 1e4}
             for m, a in zip(ws.modes, ws.area, strict=True)]
    if not args.json:
        print(f"reachable workspace of the {model.name} ({model.description.notation}){_at_alpha(model, ws.alpha)} "
              f"({resolution} x {resolution} grid, "
              f"cell {ws.cell_area * 1e4:.4g} cm^2)")
        print(table(["mode", "area (cm^2)"], [[signs(a["mode"]) if a["mode"] else "-", f"{a['area_cm2']:.2f}"]
                                              for a in areas]))
        print(f"wrote {out}")
    return {"mechanism": mechanism_name(args, model), "alpha": ws.alpha, "resolution": resolution,
            "cell_area_m2": ws.cell_area, "areas": areas,
            "figure": str(out)}


def _spatial_workspace(args, model, out: Path) -> dict:
    """``workspace`` of a spatial machine: horizontal slices of its reachable region with ``S`` and ``S = 0``."""

    from ..algorithms.analysis import spatial_workspace
    from ..views.plotting import plot_spatial_workspace

    if args.alpha is not None:
        raise InvalidParameterError("--alpha is a planar platform's orientation; a spatial machine's slices are at "
                                    "--z heights")
    resolution = check_resolution(args.resolution)
    mode = working_mode(args, model)
    levels = args.z
    with progress_bar(args, len(levels) if levels else 6, "slices") as bar:
        ws = spatial_workspace(model, mode, levels, resolution, args.x_range, args.y_range, progress=bar.update)
    if not ws.reachable.any():
        raise PkmlabError(f"nothing is reachable at z = {', '.join(f'{z:g}' for z in ws.z)} m over the region asked")
    fig = plot_spatial_workspace(ws, model=model)
    save_figure(fig, out)
    slices = [{"z": float(z), "area_m2": float(a), "area_cm2": float(a) * 1e4} for z, a in zip(ws.z, ws.area,
                                                                                            strict=True)]
    if not args.json:
        print(f"reachable workspace of the {model.name} ({model.description.notation}) in working mode "
              f"{signs(ws.mode) if ws.mode else '-'}, "
              f"{resolution} x {resolution} grid per slice")
        print(table(["z (m)", "area (cm^2)"], [[f"{s['z']:.4f}", f"{s['area_cm2']:.1f}"] for s in slices]))
        print(f"wrote {out}")
    return {"mechanism": mechanism_name(args, model), "mode": list(ws.mode), "resolution": resolution,
            "slices": slices, "figure": str(out)}
