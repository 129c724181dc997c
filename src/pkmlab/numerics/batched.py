"""Linear algebra on stacks of small matrices (K, m, m): a path's Jacobians at once."""

from __future__ import annotations

import numpy as np

from .._compile_cache import njit
from .closed_chain import lu_factor, lu_solve_factored

#: A matrix whose condition number (1-norm) reaches this is treated as singular.
CONDITION_LIMIT = 1e12
#: :func:`solve_blocks` solves a stack's diagonal blocks one by one from this size of its matrices, the whole matrices
#: below it (measured on a path's Jacobians, a thousand and more: the paper's 6×6 and the Delta's 9×9 solve as fast
#: whole as by their blocks, the Stewart platform's 18×18 twice as fast by its six blocks of three).
BLOCK_SOLVE_FROM = 12


def first_singular(a: np.ndarray, limit: float = CONDITION_LIMIT, blocks=None) -> int:
    """The index of the first singular matrix of a stack of square matrices ``a`` (K, m, m), or -1 if none is.

    A matrix is singular when its condition number in the 1-norm, ``‖A‖₁ ‖A⁻¹‖₁``, is not below ``limit`` (an
    exactly singular one's is infinite). The two condition numbers of an ``m × m`` matrix, 1- and 2-norm, differ by
    a factor of at most ``m``: a matrix within that factor of the limit may be judged either way by the two.

    A closed chain's Jacobians are often block diagonal (each leg's loop closures in its own coordinates, its rows
    and columns wherever the coordinates put them): the condition number is then that of the blocks
    (:func:`diagonal_blocks` of the entries nonzero in any matrix of the stack — an entry zero in every matrix is
    zero in each; given as ``blocks`` where the caller has them, for :func:`solve_blocks` too), found by
    :func:`first_singular_of_blocks` — compiled: NumPy's own (``np.linalg.cond``) inverts each whole matrix and spends
    about a microsecond a matrix on its bookkeeping.
    """
    a = np.ascontiguousarray(a, dtype=float)
    rows, cols, ends = diagonal_blocks(np.any(a != 0.0, axis=0)) if blocks is None else blocks
    return first_singular_of_blocks(a, rows, cols, ends, limit)


def solve_blocks(a: np.ndarray, b: np.ndarray, blocks=None) -> np.ndarray:
    """``x`` with ``a x = b`` for a stack ``a`` (K, m, m), ``b`` (K, m): NumPy's solve (LAPACK's ``gesv``), of each
    diagonal block of :func:`diagonal_blocks` (given as ``blocks``, or found from ``a``'s nonzero entries) where
    ``m`` reaches :data:`BLOCK_SOLVE_FROM`, of the whole matrix below it.

    Partial pivoting never picks a row outside a column's block (its entries there are zero), and the elimination
    adds only exact zeros to a block from outside it: the blocks' solutions are the whole matrix's, to round-off (the
    order LAPACK sums a large matrix's updates in may differ from a block's), for a fraction of the work.
    """
    m = a.shape[-1]
    if m >= BLOCK_SOLVE_FROM:
        rows, cols, ends = diagonal_blocks(np.any(a != 0.0, axis=0)) if blocks is None else blocks
        if len(ends) > 1:
            x = np.empty(b.shape)
            start = 0
            for end in ends:
                r, c = rows[start:end], cols[start:end]
                x[:, c] = np.linalg.solve(a[:, r[:, None], c], b[:, r][..., None])[..., 0]
                start = end
            return x
    return np.linalg.solve(a, b[..., None])[..., 0]


def diagonal_blocks(nonzero: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An order of the rows and one of the columns that make a square sparsity pattern block diagonal.

    ``nonzero`` (m, m) marks the entries that may be nonzero. Returns ``(rows, cols, ends)``: the rows and the
    columns in block order, and each block's end in them. The blocks are the connected parts of the graph whose
    edges are the nonzero entries (rows and columns keep their order within a block). Where a part has more columns
    than rows the matrices are singular: then one block, the whole matrix, whose factorization finds them so.
    """
    m = nonzero.shape[0]
    parent = list(range(2 * m))  # rows 0 .. m-1, columns m .. 2m-1

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in zip(*np.nonzero(nonzero), strict=True):
        parent[root(int(i))] = root(m + int(j))
    roots = [root(i) for i in range(2 * m)]
    parts = list(dict.fromkeys(roots))
    rows = [[i for i in range(m) if roots[i] == part] for part in parts]
    cols = [[j for j in range(m) if roots[m + j] == part] for part in parts]
    if any(len(r) != len(c) for r, c in zip(rows, cols, strict=True)):
        return np.arange(m), np.arange(m), np.array([m])
    return (np.array([i for part in rows for i in part], dtype=np.int64),
            np.array([j for part in cols for j in part], dtype=np.int64),
            np.cumsum([len(part) for part in rows]).astype(np.int64))


@njit(cache=True)
def first_singular_of_blocks(a, rows, cols, ends, limit):
    """:func:`first_singular` of the stack ``a`` (K, m, m) whose matrices are block diagonal in the order ``rows``,
    ``cols`` (:func:`diagonal_blocks`, blocks ending at ``ends``): a block diagonal matrix's 1-norm is the largest
    of its blocks', and so is its inverse's; each block's by
    :func:`~pkmlab.numerics.closed_chain.lu_factor` (a pivot below ``1e-14`` of the block's largest entry: singular)
    and its inverse's columns."""
    m = rows.shape[0]
    block, lu, e = np.empty((m, m)), np.empty((m, m)), np.empty(m)
    piv = np.empty(m, np.int64)
    for k in range(a.shape[0]):
        norm, inverse_norm, start = 0.0, 0.0, 0
        for b in range(ends.shape[0]):
            end = ends[b]
            s = end - start
            for r in range(s):
                for c in range(s):
                    block[r, c] = a[k, rows[start + r], cols[start + c]]
            for c in range(s):
                column = 0.0
                for r in range(s):
                    column += abs(block[r, c])
                norm = max(norm, column)
            ok, _det = lu_factor(block, lu, piv, s)
            if not ok:
                return k
            for c in range(s):  # A⁻¹ e_c
                for r in range(s):
                    e[r] = 1.0 if r == c else 0.0
                lu_solve_factored(lu, piv, e, s)
                column = 0.0
                for r in range(s):
                    column += abs(e[r])
                inverse_norm = max(inverse_norm, column)
            start = end
        if not norm * inverse_norm < limit:  # (NaN included)
            return k
    return -1
