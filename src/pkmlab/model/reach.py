"""Where a described machine's platform can be: the region it can reach, the check at load time that it
can be assembled somewhere, and the legs' closed forms of the description's kind (planar or spatial).

Everything here reads the description only (:mod:`pkmlab.description`), nothing compiled: a description
that cannot be assembled anywhere is refused before its kernels are bound (:func:`pkmlab.load`).
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np

from ..errors import InvalidParameterError


def planar_extent(description) -> tuple[tuple[float, float], tuple[float, float]]:
    """A region ``((x0, x1), (y0, y1))`` covering a planar machine's base and every leg's reach: its base points
    and rails' far ends, grown by a quarter of its longest leg (the five-bar, which works above its base
    line, by the whole leg) — where its workspace, maps and assembly check look."""
    legs = description.legs
    points = [leg.base for leg in legs]
    for leg in legs:  # a rail's far end
        if leg.joints[0].kind == "P" and leg.actuated == 0 and leg.stroke is not None:
            a = leg.joints[0].axis
            points.append((leg.base[0] + leg.stroke[1] * math.cos(a), leg.base[1] + leg.stroke[1] * math.sin(a)))
    reach = max(sum(math.hypot(*b.tip) for b in leg.bodies) + (leg.stroke[1] if leg.stroke else 0.0)
                for leg in legs)
    lo, hi = np.min(points, axis=0) - 0.25 * reach, np.max(points, axis=0) + 0.25 * reach
    if len(legs) == 2:  # the five-bar works above its base line: reach all around it
        lo, hi = np.min(points, axis=0) - reach, np.max(points, axis=0) + reach
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


#: Grids of the assembly check: positions per axis over the machine's region, and orientations; the
#: finer one is searched only when the coarse one finds no pose (a machine with a small workspace).
ASSEMBLY_GRIDS = ((81, 24), (241, 72))


def check_assembly(description) -> None:
    """Refuse a machine whose platform can be assembled nowhere: no pose on a grid over its region
    (:func:`planar_extent`, every orientation) where every leg reaches its attachment
    point in some working mode, within its stroke. Names the first leg that cannot join the others. A kinematically
    redundant leg is tried with the actuators that move its base at zero."""
    from ..description.leg_types import leg_inverse_kinematics_batch
    from ..description.leg_types import working_modes as leg_modes
    from ..description.mechanism import attachment_points

    m = description
    if getattr(m, "spatial", False):
        _check_spatial_assembly(description)
        return
    (x0, x1), (y0, y1) = planar_extent(m)
    furthest = 0  # the most legs joined at one pose, over the orientations tried
    for count, turns in ASSEMBLY_GRIDS:
        x, y = (a.ravel() for a in np.meshgrid(np.linspace(x0, x1, count), np.linspace(y0, y1, count)))
        # one orientation at a time: a machine that can be assembled is found so in the first one, usually
        rigid = m.platform.kind == "rigid"
        for alpha in (np.linspace(-np.pi, np.pi, turns, endpoint=False) if rigid else (0.0,)):
            poses = np.column_stack([x, y, np.full(x.size, alpha)])[:, :len(m.platform.pose_names)]
            # each leg is solved at the poses every leg before it reaches only, and in a working mode only where
            # none before it reached (each pose's solution is its own: the same answer, for a fraction of the work)
            together = np.arange(x.size)
            for i, leg in enumerate(m.legs):
                points = attachment_points(m, i, poses[together])
                reached = np.zeros(together.size, dtype=bool)
                for sigma in leg_modes(leg) or (1,):
                    rows = np.flatnonzero(~reached)
                    if rows.size == 0:
                        break
                    reached[rows] = ~leg_inverse_kinematics_batch(leg, i, points[rows], sigma,
                                                                  np.zeros((rows.size, leg.moving_base))).bad
                together = together[reached]
                if together.size == 0:
                    furthest = max(furthest, i)
                    break
            else:
                return
    count, turns = ASSEMBLY_GRIDS[-1]
    others = f" together with legs 1..{furthest}" if furthest > 0 else ""
    grid = f"{count} x {count} positions" + (f" x {turns} orientations" if m.platform.kind == "rigid" else "")
    raise InvalidParameterError(
        f"{m.name}: the platform can be assembled nowhere: leg {furthest + 1} reaches its attachment point{others} "
        f"at no pose of a {grid} grid over x in [{x0:.3g}, {x1:.3g}] m, y in [{y0:.3g}, {y1:.3g}] m "
        "(check the legs' lengths, strokes, bases and attachment points)")


#: Positions per axis of the spatial assembly check's grids (the platform level, over the legs' reach): the
#: coarse grid first, a subset of the fine one (41 = 5·8 + 1), so a machine that assembles is accepted after a
#: few hundred poses (a plant drawn in an uncertainty study is checked in milliseconds) and the refusal of one
#: that assembles nowhere is the fine grid's.
SPATIAL_ASSEMBLY_GRIDS = (9, 41)


def spatial_extent(description) -> np.ndarray:
    """The box (3, 2) a spatial machine's platform point can reach at most: around the legs' bases, as far
    as the longest leg reaches (its bodies' tips, its slide's upper stroke) plus the platform's size."""
    bases = np.array([leg.base for leg in description.legs])
    reach = max(sum(float(np.linalg.norm(b.tip)) for b in leg.bodies)
                + (max(abs(v) for v in leg.stroke) if leg.stroke and leg.joints[leg.actuated].kind == "P" else 0.0)
                for leg in description.legs)
    size = max(float(np.linalg.norm(a)) for a in description.platform.attachments)
    return np.column_stack([bases.min(0) - reach - size, bases.max(0) + reach + size])


def _check_spatial_assembly(description) -> None:
    """:func:`check_assembly` for a spatial machine: its computed mobility
    (:func:`~pkmlab.description.mobility.mobility`, which also finds one configuration of it), then, for a
    machine whose legs pkmlab solves in closed form on a platform of full mobility, some platform position of a
    grid over :func:`spatial_extent` (the platform level) where every leg reaches its attachment point."""
    from ..description import spatial_legs
    from ..description.mobility import mobility

    m = description
    mobility(m)
    solved = all(spatial_legs.has_closed_form(leg) for leg in m.legs)
    if m.platform.parasitic_names or not solved:
        return
    box = spatial_extent(m)
    for count in SPATIAL_ASSEMBLY_GRIDS:
        axes = [np.linspace(lo, hi, count) for lo, hi in box]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        poses = np.column_stack([points, np.zeros((len(points), m.dof - 3))])
        together = np.ones(len(poses), dtype=bool)
        for i, leg in enumerate(m.legs):
            reached = np.zeros(len(poses), dtype=bool)
            for sigma in spatial_legs.working_modes(leg) or (1,):
                reached |= ~spatial_legs.leg_inverse_kinematics_batch(
                    leg, i, attachment_points_of(m, i, poses), sigma, spatial_legs.central_axis(m)).bad
            together &= reached
            if not together.any():
                break
        else:
            return
    others = f" together with legs 1..{i}" if i > 0 else ""
    raise InvalidParameterError(
        f"{m.name}: the platform can be assembled nowhere: leg {i + 1} reaches its attachment point{others} "
        f"at no position of a {count}^3 grid over "
        + ", ".join(f"{c} in [{lo:.3g}, {hi:.3g}] m" for c, (lo, hi) in zip("xyz", box, strict=True))
        + (" (level platform)" if m.dof == 6 else "") + " (check the legs' lengths, strokes, bases and "
        "attachment points)")


def leg_solver(description) -> ModuleType:
    """The module of closed-form leg inverse kinematics for the description's kind (planar or spatial)."""
    if getattr(description, "spatial", False):
        from ..description import spatial_legs

        return spatial_legs
    from ..description import leg_types

    return leg_types


def attachment_points_of(description, leg: int, poses: np.ndarray, turns=None) -> np.ndarray:
    """Where leg ``leg`` (0-based) meets the platform at many poses, planar or spatial; ``turns``: the platform's
    :func:`platform_turns_of` those poses, where the caller has them."""
    if getattr(description, "spatial", False):
        from ..description.spatial import attachment_points

        return attachment_points(description, leg, poses, turns)
    from ..description.mechanism import attachment_points

    return attachment_points(description, leg, poses, turns)


def platform_turns_of(description, poses: np.ndarray):
    """The platform's orientation at many poses, as the description's ``attachment_points`` reads it: computed
    once for all the legs."""
    if getattr(description, "spatial", False):
        from ..description.spatial import platform_turns

        return platform_turns(description, poses)
    from ..description.mechanism import platform_turns

    return platform_turns(description, poses)
