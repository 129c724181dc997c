"""Tests of :class:`pkmlab.paper.geometry.Planar3RRR`: the paper preset, immutability, ``replace``,
per-leg parameters, validation and equality.

Expected numbers are the paper's values (docs/conventions.md) written out here, never read back from pkmlab.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from pkmlab.errors import InvalidParameterError
from pkmlab.paper.geometry import Planar3RRR

# --- the paper's manipulator (section 5), written out independently ----------------------
B = 0.52
BASE = np.array([(0.0, 0.0), (B, 0.0), (B / 2, math.sqrt(3) / 2 * B)])
L = 0.25
R = 0.1667
A = 0.125
MASS_L, MASS_R, MASS_A = 0.468, 0.312, 0.234
INERTIA_L, INERTIA_R, INERTIA_A = 2.438e-3, 0.722e-3, 0.305e-3
# Platform frame: origin at p1, x axis along p1 -> p2, equilateral of side a, counter-clockwise.
PLATFORM = np.array([(0.0, 0.0), (A, 0.0), (A / 2, math.sqrt(3) / 2 * A)])
CENTROID = np.array([A / 2, A / (2 * math.sqrt(3))])

ARRAY_ATTRIBUTES = ("base_points", "active_lengths", "passive_lengths", "active_masses", "passive_masses",
                    "active_inertias", "passive_inertias", "active_com", "passive_com", "platform_com")


@pytest.fixture(scope="module")
def paper() -> Planar3RRR:
    return Planar3RRR.paper()


def assert_names(message: str, name: str) -> None:
    """The error message starts with the parameter's name (``l (active...``, ``mass_a must...``)."""
    assert re.match(rf"{re.escape(name)}\b", message), f"message does not name {name!r}: {message!r}"


# ------------------------------------------------------------------ the paper preset
def test_paper_base_points(paper):
    np.testing.assert_allclose(paper.base_points, BASE, rtol=0, atol=1e-15)
    assert paper.base_points.shape == (3, 2)
    sides = [np.linalg.norm(paper.base_points[i] - paper.base_points[(i + 1) % 3]) for i in range(3)]
    np.testing.assert_allclose(sides, [B, B, B], rtol=1e-14)


def test_paper_lengths(paper):
    np.testing.assert_array_equal(paper.active_lengths, [L, L, L])
    np.testing.assert_array_equal(paper.passive_lengths, [R, R, R])
    assert paper.platform_side == A
    assert isinstance(paper.platform_side, float)


def test_paper_masses_and_inertias(paper):
    np.testing.assert_array_equal(paper.active_masses, [MASS_L] * 3)
    np.testing.assert_array_equal(paper.passive_masses, [MASS_R] * 3)
    assert paper.platform_mass == MASS_A
    np.testing.assert_array_equal(paper.active_inertias, [INERTIA_L] * 3)
    np.testing.assert_array_equal(paper.passive_inertias, [INERTIA_R] * 3)
    assert paper.platform_inertia == INERTIA_A
    assert isinstance(paper.platform_mass, float)
    assert isinstance(paper.platform_inertia, float)


def test_paper_mass_centres_at_midpoints_and_centroid(paper):
    np.testing.assert_allclose(paper.active_com, [(L / 2, 0.0)] * 3, rtol=0, atol=1e-15)
    np.testing.assert_allclose(paper.passive_com, [(R / 2, 0.0)] * 3, rtol=0, atol=1e-15)
    np.testing.assert_allclose(paper.platform_com, CENTROID, rtol=0, atol=1e-15)


def test_paper_platform_frame(paper):
    np.testing.assert_allclose(paper.platform_vertices, PLATFORM, rtol=0, atol=1e-15)
    np.testing.assert_allclose(paper.reference_point, CENTROID, rtol=0, atol=1e-15)
    # The centroid is equidistant (a/sqrt(3)) from the three vertices.
    dist = np.linalg.norm(paper.platform_vertices - paper.reference_point, axis=1)
    np.testing.assert_allclose(dist, [A / math.sqrt(3)] * 3, rtol=1e-14)


def test_from_params_defaults_are_the_paper_preset(paper):
    assert Planar3RRR.from_params() == paper
    explicit = Planar3RRR.from_params(b=B, l=L, r=R, a=A, mass_l=MASS_L, mass_r=MASS_R, mass_a=MASS_A,
                                      inertia_l=INERTIA_L, inertia_r=INERTIA_R, inertia_a=INERTIA_A)
    assert explicit == paper


def test_constructor_with_the_paper_arrays(paper):
    model = Planar3RRR(BASE, [L] * 3, [R] * 3, A, [MASS_L] * 3, [MASS_R] * 3, MASS_A,
                       [INERTIA_L] * 3, [INERTIA_R] * 3, INERTIA_A)
    assert model == paper


def test_b_sets_an_equilateral_base():
    model = Planar3RRR.from_params(b=0.6)
    np.testing.assert_allclose(model.base_points, [(0, 0), (0.6, 0), (0.3, 0.3 * math.sqrt(3))], atol=1e-15)


# ------------------------------------------------------------------ immutability
@pytest.mark.parametrize("name", [f.name for f in dataclasses.fields(Planar3RRR)])
def test_attributes_cannot_be_assigned(paper, name):
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(paper, name, 1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        delattr(paper, name)


def test_new_attributes_cannot_be_added(paper):
    with pytest.raises(AttributeError):
        paper.extra = 1.0  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", [*ARRAY_ATTRIBUTES, "packed"])
def test_arrays_are_read_only(paper, name):
    arr = getattr(paper, name)
    assert isinstance(arr, np.ndarray)
    assert arr.dtype == np.float64
    assert not arr.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        arr[0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        arr += 1.0


def test_model_does_not_share_the_callers_arrays():
    base = BASE.copy()
    l = np.array([L, L, 0.26])
    com = np.array([(0.1, 0.01)] * 3)
    model = Planar3RRR(base, l, [R] * 3, A, active_com=com)
    base[0] = (9.0, 9.0)
    l[:] = 9.0
    com[:] = 9.0
    np.testing.assert_allclose(model.base_points, BASE, atol=1e-15)
    np.testing.assert_array_equal(model.active_lengths, [L, L, 0.26])
    np.testing.assert_array_equal(model.active_com, [(0.1, 0.01)] * 3)
    assert l.flags.writeable, "the caller's array must not be frozen"


def test_failed_replace_leaves_the_model_unchanged(paper):
    with pytest.raises(InvalidParameterError):
        paper.replace(active_lengths=-1.0)
    np.testing.assert_array_equal(paper.active_lengths, [L, L, L])
    np.testing.assert_allclose(paper.active_com, [(L / 2, 0.0)] * 3, atol=1e-15)


# ------------------------------------------------------------------ replace()
def test_replace_without_changes_gives_an_equal_model(paper):
    copy = paper.replace()
    assert copy == paper
    assert copy is not paper


def test_replace_active_length_moves_the_active_mass_centres(paper):
    model = paper.replace(active_lengths=0.3)
    np.testing.assert_array_equal(model.active_lengths, [0.3, 0.3, 0.3])
    np.testing.assert_allclose(model.active_com, [(0.15, 0.0)] * 3, atol=1e-15)
    np.testing.assert_allclose(model.passive_com, [(R / 2, 0.0)] * 3, atol=1e-15)
    np.testing.assert_allclose(model.platform_com, CENTROID, atol=1e-15)
    # Everything else is carried over.
    np.testing.assert_array_equal(model.active_masses, [MASS_L] * 3)
    assert model.platform_inertia == INERTIA_A
    np.testing.assert_allclose(model.base_points, BASE, atol=1e-15)
    # The original is untouched.
    np.testing.assert_array_equal(paper.active_lengths, [L, L, L])


def test_replace_per_leg_passive_lengths(paper):
    r = [0.16, 0.17, 0.18]
    model = paper.replace(passive_lengths=r)
    np.testing.assert_array_equal(model.passive_lengths, r)
    np.testing.assert_allclose(model.passive_com, [(0.08, 0.0), (0.085, 0.0), (0.09, 0.0)], atol=1e-15)
    np.testing.assert_allclose(model.active_com, [(L / 2, 0.0)] * 3, atol=1e-15)


def test_replace_platform_side_moves_the_platform_centroid(paper):
    a = 0.1
    model = paper.replace(platform_side=a)
    assert model.platform_side == a
    np.testing.assert_allclose(model.platform_com, [a / 2, a / (2 * math.sqrt(3))], atol=1e-15)
    np.testing.assert_allclose(model.reference_point, [a / 2, a / (2 * math.sqrt(3))], atol=1e-15)
    np.testing.assert_allclose(model.platform_vertices, [(0, 0), (a, 0), (a / 2, a * math.sqrt(3) / 2)],
                               atol=1e-15)


def test_replace_keeps_explicit_mass_centres():
    com_l = [(0.1, 0.01), (0.11, 0.0), (0.12, -0.01)]
    com_r = [(0.05, 0.0)] * 3
    com_a = [0.05, 0.02]
    model = Planar3RRR(BASE, L, R, A, active_com=com_l, passive_com=com_r, platform_com=com_a)
    changed = model.replace(active_lengths=0.3, passive_lengths=0.18, platform_side=0.1)
    np.testing.assert_array_equal(changed.active_com, com_l)
    np.testing.assert_array_equal(changed.passive_com, com_r)
    np.testing.assert_array_equal(changed.platform_com, com_a)


def test_replace_with_explicit_mass_centre(paper):
    model = paper.replace(active_com=[(0.1, 0.0)] * 3)
    np.testing.assert_array_equal(model.active_com, [(0.1, 0.0)] * 3)
    np.testing.assert_allclose(model.passive_com, [(R / 2, 0.0)] * 3, atol=1e-15)


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"active_lengths": -0.1}, "l"),
        ({"passive_lengths": [R, 0.0, R]}, "r"),
        ({"platform_side": float("nan")}, "a"),
        ({"platform_mass": 0.0}, "mass_a"),
        ({"active_inertias": float("inf")}, "inertia_l"),
    ],
)
def test_replace_validates(paper, changes, name):
    with pytest.raises(InvalidParameterError) as info:
        paper.replace(**changes)
    assert_names(str(info.value), name)


def test_replace_refuses_an_unassemblable_platform(paper):
    with pytest.raises(InvalidParameterError, match="cannot be assembled"):
        paper.replace(platform_side=2.0)


def test_replace_refuses_collinear_base(paper):
    with pytest.raises(InvalidParameterError, match="collinear"):
        paper.replace(base_points=[(0.0, 0.0), (0.3, 0.0), (0.6, 0.0)])


# ------------------------------------------------------------------ per-leg values
def test_per_leg_values_are_accepted():
    values = {
        "l": [0.25, 0.24, 0.26],
        "r": [0.16, 0.1667, 0.17],
        "mass_l": [0.4, 0.45, 0.5],
        "mass_r": [0.3, 0.31, 0.32],
        "inertia_l": [2.0e-3, 2.4e-3, 2.5e-3],
        "inertia_r": [0.7e-3, 0.72e-3, 0.74e-3],
    }
    model = Planar3RRR.from_params(**values)
    np.testing.assert_array_equal(model.active_lengths, values["l"])
    np.testing.assert_array_equal(model.passive_lengths, values["r"])
    np.testing.assert_array_equal(model.active_masses, values["mass_l"])
    np.testing.assert_array_equal(model.passive_masses, values["mass_r"])
    np.testing.assert_array_equal(model.active_inertias, values["inertia_l"])
    np.testing.assert_array_equal(model.passive_inertias, values["inertia_r"])
    np.testing.assert_allclose(model.active_com[:, 0], np.array(values["l"]) / 2, atol=1e-15)
    np.testing.assert_allclose(model.passive_com[:, 0], np.array(values["r"]) / 2, atol=1e-15)
    np.testing.assert_array_equal(model.active_com[:, 1], 0.0)
    assert model != Planar3RRR.paper()


def test_a_single_number_applies_to_every_leg():
    model = Planar3RRR(BASE, 0.24, np.float64(0.17), A, active_masses=0.5)
    np.testing.assert_array_equal(model.active_lengths, [0.24] * 3)
    np.testing.assert_array_equal(model.passive_lengths, [0.17] * 3)
    np.testing.assert_array_equal(model.active_masses, [0.5] * 3)
    assert model.active_lengths.shape == (3,)


def test_explicit_base_points():
    base = [(0.0, 0.0), (0.5, 0.02), (0.24, 0.44)]
    model = Planar3RRR.from_params(base_points=base)
    np.testing.assert_array_equal(model.base_points, base)


# ------------------------------------------------------------------ validation
SCALAR_PARAMS = ("a", "mass_a", "inertia_a", "b")
PER_LEG_PARAMS = ("l", "r", "mass_l", "mass_r", "inertia_l", "inertia_r")
BAD_VALUES = [0.0, -0.1, -1e-300, float("nan"), float("inf"), -float("inf")]


@pytest.mark.parametrize("bad", BAD_VALUES, ids=repr)
@pytest.mark.parametrize("name", PER_LEG_PARAMS + SCALAR_PARAMS)
def test_invalid_value_is_refused(name, bad):
    with pytest.raises(InvalidParameterError) as info:
        Planar3RRR.from_params(**{name: bad})
    assert_names(str(info.value), name)


@pytest.mark.parametrize("bad", BAD_VALUES, ids=repr)
@pytest.mark.parametrize("name", PER_LEG_PARAMS)
def test_invalid_value_in_one_leg_names_the_leg(name, bad):
    good = {"l": L, "r": R, "mass_l": MASS_L, "mass_r": MASS_R, "inertia_l": INERTIA_L, "inertia_r": INERTIA_R}
    values = [good[name], bad, good[name]]
    with pytest.raises(InvalidParameterError) as info:
        Planar3RRR.from_params(**{name: values})
    message = str(info.value)
    assert_names(message, name)
    assert f"{name}2" in message


def test_invalid_parameter_error_is_a_value_error():
    with pytest.raises(ValueError):
        Planar3RRR.from_params(l=-1.0)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"l": "abc"}, "l"),
        ({"l": [L, L]}, "l"),
        ({"l": [[L, L, L]]}, "l"),
        ({"r": [R, R, "x"]}, "r"),
        ({"a": "abc"}, "a"),
        ({"a": [A, A]}, "a"),
        ({"mass_a": ["x"]}, "mass_a"),
        ({"inertia_a": [1e-3, 2e-3]}, "inertia_a"),
        ({"b": "abc"}, "b"),
        ({"base_points": "abc"}, "base_points"),
        ({"base_points": [(0, 0), (1, 0)]}, "base_points"),
        ({"base_points": [(0, 0), (1,), (0, 1)]}, "base_points"),
        ({"base_points": [(0, 0), (0.52, 0), (0.26, "x")]}, "base_points"),
    ],
)
def test_wrong_type_or_shape_is_refused(kwargs, name):
    with pytest.raises(InvalidParameterError) as info:
        Planar3RRR.from_params(**kwargs)
    assert_names(str(info.value), name)


@pytest.mark.parametrize("bad", [float("nan"), float("inf")], ids=repr)
def test_non_finite_base_point_is_refused(bad):
    base = BASE.copy()
    base[2, 1] = bad
    with pytest.raises(InvalidParameterError, match=r"base point b3\b"):
        Planar3RRR.from_params(base_points=base)


@pytest.mark.parametrize(
    "base",
    [
        [(0.0, 0.0), (0.3, 0.0), (0.6, 0.0)],  # on a line
        [(0.0, 0.0), (0.3, 0.3), (0.15, 0.15)],  # middle point between the others
        [(0.1, 0.1), (0.1, 0.1), (0.4, 0.2)],  # two coincident points
        [(0.0, 0.0), (0.0, 0.0), (0.0, 0.0)],  # all three coincident
    ],
)
def test_collinear_base_points_are_refused(base):
    with pytest.raises(InvalidParameterError, match="collinear") as info:
        Planar3RRR.from_params(base_points=base)
    assert "base" in str(info.value)


@pytest.mark.parametrize(
    "kwargs",
    [
        # Each vertex must lie within l + r = 0.4167 of its base point, so |p1 - p2| <= b + 2(l + r) = 1.353.
        {"a": 2.0},
        {"a": 1.5},
        # Base side 2: |p1 - p2| >= 2 - 2(l + r) = 1.17 > a.
        {"b": 2.0},
        # Legs far too short to reach across the base.
        {"l": 0.05, "r": 0.04},
    ],
)
def test_unassemblable_platform_is_refused(kwargs):
    with pytest.raises(InvalidParameterError, match="cannot be assembled"):
        Planar3RRR.from_params(**kwargs)


# The platform fits (with every vertex within reach of its leg, l = r so the inner radius is 0)
# iff l + r is at least the smallest possible largest-vertex distance. By symmetry that optimum is
# the platform centred on the base centroid, unrotated, each vertex pointing at its base point:
# distance b/sqrt(3) - a/sqrt(3).
CRITICAL_REACH = (B - A) / math.sqrt(3)


@pytest.mark.parametrize("factor", [1.02, 1.005])
def test_thin_feasible_set_is_found(factor):
    reach = factor * CRITICAL_REACH
    model = Planar3RRR.from_params(l=reach / 2, r=reach / 2)
    np.testing.assert_allclose(model.active_lengths + model.passive_lengths, [reach] * 3)


@pytest.mark.parametrize("factor", [0.98, 0.995])
def test_just_too_short_legs_are_refused(factor):
    reach = factor * CRITICAL_REACH
    with pytest.raises(InvalidParameterError, match="cannot be assembled"):
        Planar3RRR.from_params(l=reach / 2, r=reach / 2)


def test_mass_centre_shapes_are_checked():
    with pytest.raises(InvalidParameterError, match="active_com"):
        Planar3RRR(BASE, L, R, A, active_com=[(0.1, 0.0)] * 2)
    with pytest.raises(InvalidParameterError, match="platform_com"):
        Planar3RRR(BASE, L, R, A, platform_com=[0.1, 0.0, 0.0])
    with pytest.raises(InvalidParameterError, match="passive_com"):
        Planar3RRR(BASE, L, R, A, passive_com=[(float("nan"), 0.0)] * 3)


# ------------------------------------------------------------------ equality and hashing
def test_equal_models_are_equal_and_hash_equal(paper):
    other = Planar3RRR.paper()
    assert other is not paper
    assert other == paper
    assert not other != paper
    assert hash(other) == hash(paper)
    assert len({paper, other}) == 1
    assert {paper: "x"}[other] == "x"


def test_models_built_differently_but_equal_hash_equal(paper):
    by_points = Planar3RRR.from_params(base_points=BASE.tolist())
    by_arrays = Planar3RRR(BASE, np.full(3, L), np.full(3, R), A, np.full(3, MASS_L), np.full(3, MASS_R), MASS_A,
                           np.full(3, INERTIA_L), np.full(3, INERTIA_R), INERTIA_A,
                           active_com=[(L / 2, 0.0)] * 3)
    for model in (by_points, by_arrays):
        assert model == paper
        assert hash(model) == hash(paper)


def test_signed_zero_does_not_break_hashing(paper):
    # -0.0 == 0.0, so a base point written as -0.0 gives an equal model that must hash equal.
    negative_zero = Planar3RRR.from_params(base_points=[(-0.0, -0.0), (B, -0.0), tuple(BASE[2])])
    assert negative_zero == paper
    assert hash(negative_zero) == hash(paper)
    assert len({paper, negative_zero}) == 1


@pytest.mark.parametrize(
    "changes",
    [
        {"active_lengths": [L, L, 0.26]},
        {"passive_lengths": 0.17},
        {"platform_side": 0.12},
        {"platform_mass": 0.3},
        {"passive_inertias": [INERTIA_R, INERTIA_R, 1e-3]},
        {"platform_com": [0.06, 0.03]},
        {"base_points": [(0.0, 0.0), (B, 0.0), (B / 2, 0.44)]},
    ],
)
def test_different_models_are_not_equal(paper, changes):
    other = paper.replace(**changes)
    assert other != paper
    assert not other == paper
    assert len({paper, other}) == 2


def test_comparison_with_other_types(paper):
    assert paper != "paper"
    assert paper != None  # noqa: E711
    assert paper != paper.packed
    assert not paper == 0.125
