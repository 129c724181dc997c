"""Angles compared the shorter way round (pkmlab.numerics.angles): a gap between configurations wraps its angles
and leaves its lengths as they are."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pkmlab.numerics.angles import wrapped_angle, wrapped_where

VALUES = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)


@given(VALUES)
def test_a_wrapped_angle_is_in_the_half_open_turn_a_whole_number_of_turns_away(x):
    w = float(wrapped_angle(x))
    assert -math.pi <= w <= math.pi
    turns = (x - w) / (2 * math.pi)
    assert abs(turns - round(turns)) < 1e-9 * (1 + abs(x))


@given(st.lists(st.tuples(VALUES, st.booleans()), min_size=1, max_size=8))
def test_a_gap_wraps_its_angles_and_keeps_its_lengths(entries):
    """A slide 7 m off is 7 m off, not 7 - 2π: only the entries the mask names are angles."""
    gap = np.array([x for x, _angle in entries])
    angles = [angle for _x, angle in entries]
    got = wrapped_where(gap, angles)
    for x, angle, g in zip(gap, angles, got, strict=True):
        assert g == (wrapped_angle(x) if angle else x)
    # the mask runs along the last axis of a stack of gaps
    assert np.array_equal(wrapped_where(np.stack([gap, gap]), angles), np.stack([got, got]))


def test_a_slide_seven_metres_off_is_seven_metres_off():
    angle, length = wrapped_where(np.array([7.0, 7.0]), [True, False])
    assert angle == pytest.approx(7.0 - 2 * math.pi, abs=1e-14) and length == 7.0
