"""The singularity test and the solve of a stack of matrices (pkmlab.numerics.batched): block by block where the
matrices are block diagonal in some order of their rows and columns, as NumPy's condition number and solve of the whole
matrices judge and solve them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pkmlab.numerics.batched import (
    BLOCK_SOLVE_FROM,
    CONDITION_LIMIT,
    diagonal_blocks,
    factor_blocks,
    first_singular,
    solve_factored_blocks,
)


def _numpy_first_singular(a: np.ndarray) -> int:
    singular = ~(np.linalg.cond(a, 1) < CONDITION_LIMIT)
    return int(np.argmax(singular)) if singular.any() else -1


def _stack(seed: int, sizes: list[int], count: int, singular_at: list[int]) -> np.ndarray:
    """``count`` random matrices block diagonal with blocks of ``sizes``, rows and columns shuffled; at each sample of
    ``singular_at`` one block made singular (one of its columns a combination of the others, or all zero)."""
    rng = np.random.default_rng(seed)
    m = sum(sizes)
    a = np.zeros((count, m, m))
    start = 0
    for s in sizes:
        a[:, start:start + s, start:start + s] = rng.uniform(-1, 1, (count, s, s)) + 2 * np.eye(s)
        start += s
    for k in singular_at:
        b = rng.integers(len(sizes))
        lo = sum(sizes[:b])
        block = a[k, lo:lo + sizes[b], lo:lo + sizes[b]]
        block[:, -1] = block[:, :-1] @ rng.uniform(-1, 1, sizes[b] - 1) if sizes[b] > 1 else 0.0
    return a[:, rng.permutation(m)][:, :, rng.permutation(m)]


@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 4), min_size=1, max_size=5), st.integers(1, 12),
       st.lists(st.integers(0, 11), max_size=3))
def test_the_first_singular_matrix_is_numpys(seed, sizes, count, singular_at):
    a = _stack(seed, sizes, count, [k for k in singular_at if k < count])
    assert first_singular(a) == _numpy_first_singular(a)
    assert factor_blocks(a, blocks=diagonal_blocks(np.any(a != 0.0, axis=0))).singular == first_singular(a)
    assert factor_blocks(a).singular == first_singular(a)


@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 4), min_size=1, max_size=5))
def test_the_blocks_hold_every_nonzero_entry_and_each_row_and_column_once(seed, sizes):
    nonzero = np.any(_stack(seed, sizes, 3, []) != 0, axis=0)
    rows, cols, ends = diagonal_blocks(nonzero)
    m = nonzero.shape[0]
    assert sorted(rows) == list(range(m)) and sorted(cols) == list(range(m)) and ends[-1] == m
    assert len(ends) == len(sizes)  # random blocks are not split further, nor merged
    inside = np.zeros_like(nonzero)
    for start, end in zip([0, *ends[:-1]], ends, strict=True):
        inside[np.ix_(rows[start:end], cols[start:end])] = True
    assert not (nonzero & ~inside).any()


def test_a_column_of_zeros_is_singular_at_every_matrix():
    a = _stack(1, [2, 3], 4, [])
    a[:, :, 3] = 0.0  # the blocks' graph then has a part of more columns than rows: the whole matrix, one block
    assert diagonal_blocks(np.any(a != 0, axis=0))[2].tolist() == [5]
    assert first_singular(a) == 0 == _numpy_first_singular(a)


def test_non_finite_entries_are_singular_as_numpy_judges_them():
    a = _stack(2, [3, 3], 5, [])
    a[3, 1, 2] = np.nan
    a[2, 0, 0] = np.inf
    assert first_singular(a) == 2 == _numpy_first_singular(a)
    assert first_singular(a[3:]) == 0 == _numpy_first_singular(a[3:])


@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 6), min_size=1, max_size=8), st.integers(1, 12))
def test_the_blocks_solution_is_numpys_of_the_whole_matrix(seed, sizes, count):
    """Large stacks solved with their blocks' factors, small ones by NumPy's solve of the whole (then the very same
    numbers); either way the solution of the whole matrices, to round-off, whether the blocks are given or found."""
    a = _stack(seed, sizes, count, [])
    b = np.random.default_rng(seed + 1).uniform(-1, 1, a.shape[:2])
    factors = factor_blocks(a)
    assert factors.singular == -1
    x = solve_factored_blocks(factors, a, b)
    whole = np.linalg.solve(a, b[..., None])[..., 0]
    if a.shape[-1] < BLOCK_SOLVE_FROM:
        assert np.array_equal(x, whole)
    np.testing.assert_allclose(x, whole, rtol=0, atol=1e-12 * np.abs(whole).max())
    np.testing.assert_allclose(np.einsum("kij,kj->ki", a, x), b, rtol=0, atol=1e-12)
    given = factor_blocks(a, blocks=diagonal_blocks(np.any(a != 0.0, axis=0)))
    assert np.array_equal(solve_factored_blocks(given, a, b), x)


def test_a_large_stack_is_solved_by_its_blocks():
    """Past the size where it pays, each block is solved alone with its own factors: a block's unknowns are its own
    system's solution, whatever the other blocks hold; a stack with a singular matrix is refused, not solved."""
    sizes = [3] * (BLOCK_SOLVE_FROM // 3 + 1)
    a = _stack(5, sizes, 4, [])
    b = np.random.default_rng(6).uniform(-1, 1, a.shape[:2])
    rows, cols, ends = blocks = diagonal_blocks(np.any(a != 0.0, axis=0))
    assert len(ends) == len(sizes)
    x = solve_factored_blocks(factor_blocks(a, blocks=blocks), a, b)
    first = np.linalg.solve(a[:, rows[:3]][:, :, cols[:3]], b[:, rows[:3], None])[..., 0]
    np.testing.assert_allclose(x[:, cols[:3]], first, rtol=0, atol=1e-13)
    changed = a.copy()
    changed[:, rows[3:, None], cols[3:]] *= 2.0  # the other blocks only
    assert np.array_equal(solve_factored_blocks(factor_blocks(changed, blocks=blocks), changed, b)[:, cols[:3]],
                          x[:, cols[:3]])
    a[1, rows[0], cols[0]] = np.nan  # the first entry a block's norms see: a NaN there was once dropped by max()
    factors = factor_blocks(a, blocks=blocks)
    assert factors.singular == 1 == first_singular(a) == _numpy_first_singular(a)
    with pytest.raises(ValueError, match="matrix 1 of the stack is singular"):
        solve_factored_blocks(factors, a, b)


@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 4), min_size=1, max_size=5), st.integers(1, 6),
       st.lists(st.integers(0, 5), max_size=2), st.integers(0, 3), st.booleans())
def test_columns_read_in_place_are_the_matrices_of_those_columns(seed, sizes, count, singular_at, extra, run):
    """A path's Jacobians hold every coordinate's column; the stack of some of them (a run of columns, or any) is
    factored where it lies, with the factors, pivots and verdict of the same columns copied out, bit for bit."""
    square = _stack(seed, sizes, count, [k for k in singular_at if k < count])
    m = square.shape[-1]
    rng = np.random.default_rng(seed + 2)
    columns = slice(extra, extra + m) if run else rng.permutation(m + extra)[:m]
    wide = rng.uniform(-1, 1, (count, m, m + extra))  # the other columns: anything
    wide[:, :, columns] = square
    copied, in_place = factor_blocks(square), factor_blocks(wide, columns=columns)
    assert in_place.singular == copied.singular == first_singular(square)
    for name in ("rows", "cols", "ends", "lu", "piv"):
        mine, theirs = getattr(in_place, name), getattr(copied, name)
        assert (mine is None and theirs is None) or np.array_equal(mine, theirs), name
    if copied.singular < 0:
        b = rng.uniform(-1, 1, (count, m))
        assert np.array_equal(solve_factored_blocks(in_place, square, b), solve_factored_blocks(copied, square, b))
