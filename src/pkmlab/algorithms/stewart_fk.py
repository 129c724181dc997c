"""Forward kinematics of the general Stewart–Gough platform (6-SPS / 6-UPS): every real assembly mode.

Six legs join base points ``b_i`` (world frame) to platform points ``a_i`` (platform frame); given the
six leg lengths ``rho_i``, the platform's poses ``(R, p)`` — platform point ``i`` at ``p + R a_i`` —
are the solutions of ``|p + R a_i - b_i|² = rho_i²``. A general platform has 40 of them over the
complex numbers, and all 40 can be real (Dietmaier 1998). :func:`assembly_modes` returns every real
one, found by polynomial homotopy continuation.

Formulation (soma / Study coordinates, Wampler 1996). A pose is written with two quaternions
``e = (e0, e1, e2, e3)`` (the rotation, ``R v = e v e* / |e|²``) and ``g = p e`` (quaternion product,
``p = (0, p)``), so that ``p = g e* / |e|²``. With ``a = (0, a_i)`` and ``b = (0, b_i)``, multiplying
a leg equation by ``|e|²`` turns it into a quadratic form in ``x = (e, g)``::

    g·g + 2 g·(e a − b e) − 2 (b e)·(e a) + (|a_i|² + |b_i|² − rho_i²) e·e = 0

(``·`` the Euclidean product of R⁴). ``g e*`` must be a pure quaternion, which is the Study quadric
``e·g = 0``. Seven homogeneous quadrics in the projective space P⁷: Bézout number 2⁷ = 128. Of the 128
solutions counted with multiplicity, the finite ones (``e ≠ 0``) are the poses, at most 40; the rest lie
on the degenerate set ``e = 0, g·g = 0``, where every equation vanishes.

Method. A total-degree homotopy ``H(x, t) = (1 − t) F(x) + γ t G(x)`` with ``G_k = x_k² − x_7²``
(``k = 0..6``, 128 start points ``x = (±1, ..., ±1, 1)``), a random complex ``γ`` (the gamma trick: for all but
finitely many ``γ`` on the unit circle no path meets a singularity for ``t ∈ (0, 1]``), on a random complex
affine patch ``c·x = 1`` (no path then runs off to infinity). The 128 paths are tracked each with its own
adaptive step: a fourth-order Runge–Kutta predictor on the Davidenko equation ``dx/dt = −H_x⁻¹ H_t`` and a
Newton corrector that must contract fast, else the step is halved (:func:`pkmlab.numerics.tracker.track_paths`,
on a straight-line program of the homotopy written as a family ``s₀ F(x) + s₁ G(x)`` whose parameters
``(s₀, s₁)`` go from ``(0, γ)`` to ``(1, 0)``). The paths stop at a small ``t``; the end game is Newton's method on
``F`` at ``t = 0``: a path to a pose ends at a regular solution, where it converges quadratically and ``e`` is
of the size of ``x``; a path to the degenerate set ends where the Jacobian is singular and ``e → 0`` (like
``√t``: its tracking stops near ``t ≈ 1e-8``, and ``|e| / |x|`` is then some 1e-4, against at least
``1 / √(1 + B²)`` at a real pose, ``B`` a bound of ``|p|`` from the leg lengths). The finite solutions that are real (up
to the projective scale) become ``(R, p)``, which Newton's method polishes on the six leg equations themselves
(``R ← R exp([δ]×)``, ``p ← p + dp``).

Checks of completeness. The leg lengths are real, so the complex solutions come in conjugate pairs;
two paths must not end at the same regular solution (a path jumped); no path may end undecided (a
singular endpoint with ``e`` not small: a double root, e.g. at a singularity of the platform). A run
that fails any of these is repeated with another ``γ`` and patch and the solutions are merged; if none
passes, :class:`~pkmlab.errors.IncompleteSolutionWarning` says so.

References: C. W. Wampler, "Forward displacement analysis of general six-in-parallel SPS (Stewart)
platform manipulators using soma coordinates", Mechanism and Machine Theory 31(3), 1996, 331–337;
P. Dietmaier, "The Stewart–Gough platform of general geometry can have 40 real postures", Advances in
Robot Kinematics: Analysis and Control, Kluwer, 1998, 7–16.
"""

from __future__ import annotations

import functools
import math
import operator
import warnings

import numpy as np

from ..errors import IncompleteSolutionWarning, InvalidParameterError, shown
from ..numerics.homotopy import Family, batched_solve
from ..numerics.straight_line import cached_program, compile_program
from ..numerics.tracker import track_paths

__all__ = ["assembly_modes"]

#: Number of paths of the total-degree homotopy (Bézout number of seven quadrics in P⁷).
_N_PATHS = 128
#: Largest number of finite solutions of a general platform.
_MAX_SOLUTIONS = 40
#: Runs with a new gamma and patch when a run fails a completeness check.
_ATTEMPTS = 3
#: The paths stop at this t; the end game then works at t = 0.
_T_END = 1e-10
#: A path that stops before this t is a failure (the paths to e = 0 stop later).
_LATE = 1e-4
#: Most predictor-corrector iterations per path.
_MAX_STEPS = 5000
#: Largest |Im| (relative) of a projectively normalised solution worth polishing as a real pose.
_IMAG_TOL = 1e-4
#: Required accuracy of the leg lengths, relative to the size of the machine.
_LEG_TOL = 1e-10
#: Two poses closer than this (rotation matrices, positions over the machine's size) are one.
_SAME_POSE = 1e-7


# --------------------------------------------------------------------------- quaternions


def _left(q) -> np.ndarray:
    """The 4×4 matrix ``L(q)`` of ``r ↦ q r`` (Hamilton product, ``q = (w, x, y, z)``)."""
    w, x, y, z = q
    return np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])


def _right(q) -> np.ndarray:
    """The 4×4 matrix ``R(q)`` of ``r ↦ r q``."""
    w, x, y, z = q
    return np.array([[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]])


def _pure(v) -> np.ndarray:
    """The pure quaternion ``(0, v)``."""
    return np.concatenate(([0.0], np.asarray(v, dtype=float)))


def rotation_of_quaternion(e: np.ndarray) -> np.ndarray:
    """The rotation matrix ``v ↦ e v e* / |e|²`` of a real non-zero quaternion ``e``."""
    w, x, y, z = np.asarray(e, dtype=float) / np.linalg.norm(e)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _quaternion_of(R: np.ndarray) -> np.ndarray:
    """A unit quaternion ``e`` with ``rotation_of_quaternion(e) == R`` (of a proper rotation matrix ``R``)."""
    R = np.asarray(R, dtype=float)
    K = np.array([  # Bar-Itzhack: e is the eigenvector of the largest eigenvalue of this symmetric matrix
        [R[0, 0] + R[1, 1] + R[2, 2], R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]],
        [R[2, 1] - R[1, 2], R[0, 0] - R[1, 1] - R[2, 2], R[0, 1] + R[1, 0], R[0, 2] + R[2, 0]],
        [R[0, 2] - R[2, 0], R[0, 1] + R[1, 0], R[1, 1] - R[0, 0] - R[2, 2], R[1, 2] + R[2, 1]],
        [R[1, 0] - R[0, 1], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1], R[2, 2] - R[0, 0] - R[1, 1]],
    ])
    _, vectors = np.linalg.eigh(K)
    return vectors[:, -1]


def _study_of(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Soma coordinates ``x = (e, g)``, ``g = p e``, of the pose ``(R, p)`` (``|e| = 1``)."""
    e = _quaternion_of(R)
    return np.concatenate((e, _left(_pure(p)) @ e))


def _pose_of(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pose ``(R, p)`` of real soma coordinates ``x = (e, g)`` with ``e ≠ 0``: ``p = g e* / |e|²``."""
    x = np.asarray(x, dtype=float)
    e, g = x[:4], x[4:]
    conj = e * np.array([1.0, -1.0, -1.0, -1.0])
    return rotation_of_quaternion(e), (_left(g) @ conj)[1:] / (e @ e)


# --------------------------------------------------------------------------- the polynomial system


def _quadrics(base: np.ndarray, platform: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The seven symmetric 8×8 matrices ``Q_k`` of the system ``xᵀ Q_k x = 0``, ``x = (e, g)``.

    ``Q_0..Q_5`` are the legs: ``xᵀ Q_i x = |e|² (|p + R a_i − b_i|² − rho_i²)`` at the soma
    coordinates of ``(R, p)``; ``Q_6`` is the Study quadric ``e·g``.
    """
    Q = np.zeros((7, 8, 8))
    eye = np.eye(4)
    for i in range(6):
        a, b = _pure(platform[i]), _pure(base[i])
        Ra, Lb = _right(a), _left(b)
        c = a @ a + b @ b - lengths[i] ** 2
        Q[i, :4, :4] = c * eye - (Lb.T @ Ra + Ra.T @ Lb)
        Q[i, 4:, :4] = Ra - Lb
        Q[i, :4, 4:] = (Ra - Lb).T
        Q[i, 4:, 4:] = eye
    Q[6, :4, 4:] = Q[6, 4:, :4] = eye / 2
    return Q


# --------------------------------------------------------------------------- path tracking


#: Pairs (i, j), i <= j, of the upper triangle of a symmetric 8×8 matrix: a leg quadric's coefficients.
_UPPER = [(i, j) for i in range(8) for j in range(i, 8)]


@functools.cache
def _family() -> Family:
    """:func:`_soma_program` as a family (derived once per installation, then read from the cache folder)."""
    return Family(cached_program("stewart_soma", _soma_program), 8, 2, scale=0.0)


def _soma_program():
    """The straight-line program (:mod:`pkmlab.numerics.straight_line`) of the homotopy
    ``H(x, t) = (1 − t) F(x) + γ t G(x)`` with the patch ``c·x = 1``, written as a family ``s₀ F(x) + s₁ G(x)`` whose
    two moving parameters go from ``(0, γ)`` at ``t = 1`` to ``(1, 0)`` at ``t = 0``, its fixed parameters the six
    leg quadrics' upper triangles and the patch: the same for every platform."""
    import sympy as sp

    x = sp.symbols("x0:8")
    s0, s1 = sp.symbols("s0 s1")
    q = [sp.symbols(f"q{k}_0:{len(_UPPER)}") for k in range(6)]
    c = sp.symbols("c0:8")
    study = _quadrics(np.zeros((6, 3)), np.zeros((6, 3)), np.zeros(6))[6]
    H = []
    for k in range(7):
        if k < 6:
            F = sum((1 if i == j else 2) * q[k][u] * x[i] * x[j] for u, (i, j) in enumerate(_UPPER))
        else:
            F = sum(sp.nsimplify(study[i, j]) * x[i] * x[j] for i in range(8) for j in range(8))
        H.append(s0 * F + s1 * (x[k] ** 2 - x[7] ** 2))
    H.append(sum(ci * xi for ci, xi in zip(c, x, strict=True)) - 1)
    H = sp.Matrix(H)
    fixed = [v for row in q for v in row] + list(c)
    return compile_program([*H, *H.jacobian(x), *H.jacobian([s0, s1])], [*x, s0, s1, *fixed])


def _parameters(Q: np.ndarray, s: tuple[complex, complex], patch: np.ndarray) -> np.ndarray:
    """The family's parameters: ``s``, then the leg quadrics' upper triangles, then the patch."""
    upper = [Q[k, i, j] for k in range(6) for i, j in _UPPER]
    return np.array([*s, *upper, *patch], dtype=complex)


def _start_points(patch: np.ndarray) -> np.ndarray:
    """The 128 solutions ``(±1, ..., ±1, 1)`` of ``G = 0``, scaled onto the patch ``c·x = 1``."""
    signs = 1 - 2 * ((np.arange(_N_PATHS)[:, None] >> np.arange(7)) & 1)
    x = np.concatenate((signs, np.ones((_N_PATHS, 1))), axis=1).astype(complex)
    return x / (x @ patch)[:, None]


def _end_game(Q: np.ndarray, patch: np.ndarray, x: np.ndarray, iterations: int = 8):
    """Newton's method on ``F = 0, c·x = 1`` (``t = 0``) from the endpoints ``x``.

    Returns the refined points, whether Newton converged to a regular solution (last correction at
    rounding level, a well-conditioned Jacobian) and the ratio ``|e| / |x|``.
    """
    Qc = Q.astype(complex)
    x = x.copy()
    last = np.full(x.shape[0], np.inf)
    for _ in range(iterations):
        Qx = np.einsum("kij,pj->pki", Qc, x)
        J = np.empty((x.shape[0], 8, 8), dtype=complex)
        J[:, :7] = 2 * Qx
        J[:, 7] = patch
        rhs = np.empty((x.shape[0], 8), dtype=complex)
        rhs[:, :7] = -np.einsum("pki,pi->pk", Qx, x)
        rhs[:, 7] = 1 - x @ patch
        dx = batched_solve(J, rhs)
        bad = ~np.isfinite(dx).all(axis=1)
        dx[bad] = 0
        last = np.where(bad, np.inf, np.linalg.norm(dx, axis=1))
        x = x + dx
    Qx = np.einsum("kij,pj->pki", Qc, x)
    J = np.empty((x.shape[0], 8, 8), dtype=complex)
    J[:, :7] = 2 * Qx
    J[:, 7] = patch
    sv = np.linalg.svd(J, compute_uv=False)
    norm = np.linalg.norm(x, axis=1)
    rcond = sv[:, -1] / sv[:, 0]
    regular = (last <= 1e-11 * norm) & (rcond > 1e-13)
    ratio = np.linalg.norm(x[:, :4], axis=1) / norm
    return x, regular, ratio


def _projective_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sine of the angle between the complex lines of ``x`` and ``y`` (rows; 0 for one projective point)."""
    inner = np.abs(np.einsum("...i,...i->...", np.conj(x), y))
    cos = inner / (np.linalg.norm(x, axis=-1) * np.linalg.norm(y, axis=-1))
    return np.sqrt(np.maximum(0.0, 1 - cos**2))


def _distinct(points: list[np.ndarray], tol: float = 1e-8) -> list[np.ndarray]:
    """``points`` without the repeats of a projective point."""
    out: list[np.ndarray] = []
    for x in points:
        if not out or _projective_distance(np.array(out), x).min() > tol:
            out.append(x)
    return out


def _run(Q: np.ndarray, rng: np.random.Generator, real_ratio: float):
    """One total-degree homotopy run with a random ``γ`` and patch.

    Returns ``(solutions, singular, problems)``: the regular finite solutions found (projective
    points, unit norm, without repeats), the singular endpoints that may be real poses (worth a
    polish, not vouched for) and the reasons to distrust the run (empty for a clean run).
    ``real_ratio`` is a lower bound of ``|e| / |x|`` at the real poses.
    """
    gamma = np.exp(2j * np.pi * rng.random())
    patch = (rng.standard_normal(8) + 1j * rng.standard_normal(8)) / 4
    family = _family()
    program = family.program
    # a projective system on a patch: no scale floor, no divergence, stalls judged at any t
    starts = _start_points(patch)
    p0, p1 = (np.tile(_parameters(Q, s, patch), (len(starts), 1)) for s in ((0, gamma), (1, 0)))  # one row a path
    ends, t_stop, _diverged = track_paths(program.code, program.register_file(), program.outputs, 8, 2, starts, p0,
                                          p1, _T_END, 0.0, math.inf, _MAX_STEPS, 0.0)
    with np.errstate(all="ignore"):
        x, regular, ratio = _end_game(Q, patch, ends)
    x = x / np.linalg.norm(x, axis=1)[:, None]
    problems = []
    early = ~regular & (t_stop > _LATE)
    if early.any():
        problems.append(f"{int(early.sum())} path(s) failed at t > {_LATE:g}")
    # A singular endpoint away from the degenerate set e = 0: a double root, or a curve of poses.
    undecided = ~regular & (ratio > 0.1 * real_ratio)
    if undecided.any():
        problems.append(f"{int(undecided.sum())} path(s) ended at a singular solution")
    sols = list(x[regular & (ratio > 1e-8)])
    unique = _distinct(sols, 1e-6)
    if len(unique) < len(sols):
        problems.append(f"{len(sols) - len(unique)} path(s) jumped to a solution already found")
    if len(unique) > _MAX_SOLUTIONS:
        problems.append(f"{len(unique)} finite solutions, more than {_MAX_SOLUTIONS}")
    if unique:
        arr = np.array(unique)
        lonely = sum(_projective_distance(arr, np.conj(v)).min() > 1e-6 for v in arr)
        if lonely:
            problems.append(f"{lonely} complex solution(s) without their conjugate")
    return unique, list(x[undecided & np.isfinite(x).all(axis=1)]), problems


# --------------------------------------------------------------------------- real poses


def _polish(base, platform, lengths, R, p, iterations: int = 30):
    """Newton's method on the six leg equations ``|p + R a_i − b_i|² = rho_i²`` from ``(R, p)``.

    The rotation moves as ``R exp([δ]×)``. Returns the best iterate ``(R, p, err)``,
    ``err = max_i ||p + R a_i − b_i| − rho_i|``; stops when ``err`` stops decreasing.
    """
    best = None
    stalled = 0
    for _ in range(iterations + 1):
        Ra = platform @ R.T  # rows R a_i
        d = p + Ra - base
        dist = np.linalg.norm(d, axis=1)
        err = float(np.abs(dist - lengths).max())
        if not np.isfinite(err):
            break
        if best is None or err < best[2]:
            best, stalled = (R, p, err), 0
        else:
            stalled += 1
            if stalled >= 2:
                break
        # d(|d_i|²) = 2 d_i·(R (δ × a_i) + dp) = 2 (Rᵀ (R a_i × d_i))·δ + 2 d_i·dp
        J = 2 * np.concatenate((np.cross(Ra, d) @ R, d), axis=1)
        try:
            step = np.linalg.solve(J, lengths**2 - dist**2)
        except np.linalg.LinAlgError:
            break
        R = R @ _expm_so3(step[:3])
        p = p + step[3:]
    return best


def _expm_so3(w: np.ndarray) -> np.ndarray:
    """``exp([w]×)`` (Rodrigues)."""
    angle = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if angle < 1e-8:
        return np.eye(3) + K + K @ K / 2
    return np.eye(3) + math.sin(angle) / angle * K + (1 - math.cos(angle)) / angle**2 * K @ K


def _real_representative(x: np.ndarray) -> np.ndarray | None:
    """The real point of the projective class of ``x`` if there is one (up to ``_IMAG_TOL``), else None."""
    k = int(np.argmax(np.abs(x)))
    y = x * (np.conj(x[k]) / abs(x[k]))
    y = y / np.linalg.norm(y)
    if np.abs(y.imag).max() > _IMAG_TOL:
        return None
    return y.real


def _as_points(name: str, value) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a (6, 3) array of numbers, got {shown(value)}") from None
    if arr.shape != (6, 3):
        raise InvalidParameterError(f"{name} must be a (6, 3) array (six points), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidParameterError(f"{name} must be finite, got {shown(arr.tolist())}")
    return arr


def _check(base, platform, lengths, seed):
    base = _as_points("base", base)
    platform = _as_points("platform", platform)
    try:
        rho = np.array(lengths, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"lengths must be six numbers, got {shown(lengths)}") from None
    if rho.shape != (6,):
        raise InvalidParameterError(f"lengths must be six numbers (shape (6,)), got shape {rho.shape}")
    if not np.isfinite(rho).all() or (rho <= 0).any():
        raise InvalidParameterError(f"leg lengths must be finite and positive, got {shown(rho.tolist())}")
    if isinstance(seed, bool):
        raise InvalidParameterError(f"seed must be an integer, got {seed!r}")
    try:
        seed = operator.index(seed)
    except TypeError:
        raise InvalidParameterError(f"seed must be an integer, got {shown(seed)}") from None
    if seed < 0:
        raise InvalidParameterError(f"seed must be non-negative, got {seed}")
    return base, platform, rho, seed


def assembly_modes(base, platform, lengths, *, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every real assembly mode of a Stewart–Gough platform, by homotopy continuation.

    Each pose is polished so that ``max_i | |p + R a_i − b_i| − rho_i | < 1e-10 · size`` (``size``: the largest
    of the leg lengths and of the distances of the points from their centroids). At most 40 poses (a general
    platform). ``seed`` fixes the random complex constants of the homotopy: the result is deterministic for a
    given seed.

    Parameters
    ----------
    base : array_like, shape (6, 3)
        The base points ``b_i`` in the world frame (m).
    platform : array_like, shape (6, 3)
        The platform points ``a_i`` in the platform frame (m).
    lengths : array_like, shape (6,)
        The leg lengths ``rho_i`` (m), leg ``i`` joining ``b_i`` to ``a_i``; finite and positive.
    seed : int
        Non-negative: the seed of the homotopy's random constants.

    Returns
    -------
    list of tuple (ndarray, ndarray)
        The poses ``(R, p)`` — ``R`` (3, 3) a rotation matrix, ``p`` (3,) in m — with platform point ``i`` at
        ``p + R a_i``, sorted by ``p`` then ``R``, lexicographically. An empty list: the legs cannot be
        assembled.

    Raises
    ------
    InvalidParameterError
        For arrays of the wrong shape, non-finite values, non-positive lengths, or a seed that is not a
        non-negative integer.

    Warns
    -----
    IncompleteSolutionWarning
        Where the method cannot vouch for completeness (a double root, a non-general platform with infinitely
        many poses): real assembly modes may be missing.

    Examples
    --------
    >>> import numpy as np
    >>> b, a = np.deg2rad([0, 100, 120, 220, 240, 340]), np.deg2rad([40, 80, 160, 200, 280, 320])
    >>> base = np.c_[np.cos(b), np.sin(b), np.zeros(6)]
    >>> platform = 0.5 * np.c_[np.cos(a), np.sin(a), np.zeros(6)]
    >>> p = np.array([0.1, -0.05, 0.8])
    >>> lengths = np.linalg.norm(p + platform - base, axis=1)
    >>> modes = assembly_modes(base, platform, lengths)
    >>> any(np.allclose(R, np.eye(3)) and np.allclose(q, p) for R, q in modes)
    True
    """
    base, platform, rho, seed = _check(base, platform, lengths, seed)
    cb, ca = base.mean(axis=0), platform.mean(axis=0)
    size = max(np.linalg.norm(base - cb, axis=1).max(), np.linalg.norm(platform - ca, axis=1).max(), rho.max())
    nb, na, nr = (base - cb) / size, (platform - ca) / size, rho / size
    Q = _quadrics(nb, na, nr)
    # A real pose has |p| <= |b_i| + rho_i + |a_i| (normalised coordinates), so at its soma coordinates
    # |e| / |x| = 1 / sqrt(1 + |p|²) is at least real_ratio.
    bound = float((np.linalg.norm(nb, axis=1) + nr + np.linalg.norm(na, axis=1)).min())
    real_ratio = 1 / math.sqrt(1 + bound**2)

    rng = np.random.default_rng(seed)
    found: list[np.ndarray] = []
    problems: list[str] = []
    for _ in range(_ATTEMPTS):
        sols, singular, problems = _run(Q, rng, real_ratio)
        found = _distinct(found + sols + singular, 1e-8)
        if not problems:
            break
    if problems:
        warnings.warn(f"Stewart–Gough forward kinematics: after {_ATTEMPTS} homotopy runs, {'; '.join(problems)}: "
                      f"real assembly modes may be missing", IncompleteSolutionWarning, stacklevel=2)

    poses: list[tuple[np.ndarray, np.ndarray]] = []
    for x in found:
        y = _real_representative(x)
        if y is None or np.linalg.norm(y[:4]) < 1e-8:
            continue
        Rn, pn = _pose_of(y)
        R, p = Rn, size * pn + cb - Rn @ ca
        R, p, err = _polish(base, platform, rho, R, p)
        if err > _LEG_TOL * size:
            continue
        if any(np.abs(R - R2).max() + np.abs(p - p2).max() / size < _SAME_POSE for R2, p2 in poses):
            continue
        poses.append((R, p))
    poses.sort(key=lambda rp: (*rp[1], *rp[0].ravel()))
    return poses
