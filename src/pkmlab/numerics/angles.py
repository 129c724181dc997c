"""Angles compared the shorter way round."""

from __future__ import annotations

import numpy as np


def wrapped_angle(angle):
    """``angle`` (radians, any shape) taken into ``(-π, π]``: the difference of two angles the shorter way round.

    The argument of ``exp(i angle)``, so a value a whole number of turns away maps to the same one. The compiled
    kernels' scalar counterpart is ``wrapped`` (:mod:`pkmlab.codegen.core.workspace`)."""
    return np.angle(np.exp(1j * angle))


def wrapped_where(difference, angles):
    """``difference`` (any shape) with its entries that are angles (``angles``, a boolean mask over its last axis)
    taken into ``(-π, π]`` by :func:`wrapped_angle`, the others (lengths: a slide's, a pose's position) as they
    are: the gap between two configurations, coordinate by coordinate."""
    out = np.array(difference, dtype=float)  # a copy
    angles = np.asarray(angles, dtype=bool)
    out[..., angles] = wrapped_angle(out[..., angles])
    return out
