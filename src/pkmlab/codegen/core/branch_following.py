"""The compiled core, branch following (the paper's §3.2): the passive coordinates at new actuator values by the chord
and Newton's methods from the base configuration, with the gain-type singularity measure ``S`` and its guard.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    import numpy as np

    from pkmlab._compile_cache import NO_REFCOUNT, NO_REFCOUNT_INLINE, NO_REFCOUNT_PYTHON, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import (
        ANGLES,
        BLOCK_END,
        DIM,
        MEASURE_LINES,
        N_ACTUATORS,
        N_CONSTRAINTS,
        N_COORDINATES,
        N_INDEPENDENT,
        N_LEGS,
        POINT_COLUMNS,
        POINT_ROWS,
        REDUCED_COLUMNS,
        REDUCED_SIGN,
        constraint_jacobian,
        constraints,
        leg_lines,
        platform_size,
        trig,
        trig_passive,
    )
    from pkmlab.numerics.closed_chain import lu_factor, lu_solve_factored

    from .workspace import (
        BASE,
        BLOCK_START,
        BLOCKED,
        ELIMINATED,
        MAX_CHORD,
        MAX_NEWTON,
        MAX_NEWTON_STEP,
        NEWTON_STEP,
        NOT_CONVERGED,
        OK,
        REDUCED,
        SINGULAR,
        TRIAL,
        actuator_error,
        dependent_column,
        independent_column,
    )

# ==== TEMPLATE
@njit(**NO_REFCOUNT_INLINE)
def reduced_column(k):
    """The column of Jηφ of the k-th coordinate of the reduced system (the tracked point skipped)."""
    return REDUCED_COLUMNS[k]


#: The smallest normal float64: a coordinate below it in magnitude is zero to within any tolerance.
SMALLEST_NORMAL = 2.2250738585072014e-308


@njit(**NO_REFCOUNT_INLINE)
def settled(v):
    """A coordinate just updated by Newton's method, a subnormal value taken as the zero it approaches (its sign
    kept): a coordinate whose solution is 0 (a platform's parasitic roll held level) is approached by quadratic steps
    that end in the subnormal numbers, every operation on which takes microcode a hundred times slower (the 4-RUU's
    loop ran 4× slower with its roll and pitch at -5e-324). Any other value (NaN too) as it is."""
    return v * 0.0 if abs(v) < SMALLEST_NORMAL else v


@njit(**NO_REFCOUNT)
def passive_solve(lu, piv, top, b, work):
    """Overwrite ``b`` (m,) with ``Jηφ⁻¹ b`` from the factors of the reduced system (:func:`factor_passive`):
    its rows are the constraints' rows ELIMINATED.. minus row 0 (x), 1 (y) or 2 (z) (the point rows; the rows after
    them do not move with the tracked point), free of the tracked point; then the tracked point from rows
    0 .. ELIMINATED - 1 (``top``: their entries in the reduced system's columns). With the tracked point independent
    (``ELIMINATED = 0``) the reduced system is ``Jηφ``. ``work`` is an (m,) scratch array."""
    for r in range(REDUCED):
        if ELIMINATED == 0:
            work[r] = b[r]
        else:
            work[r] = b[r + ELIMINATED] - b[r % ELIMINATED] if r + ELIMINATED < POINT_ROWS else b[r + ELIMINATED]
    if BLOCKED:
        block_lu_solve(lu, piv, work)
    else:
        lu_solve_factored(lu, piv, work, REDUCED)
    for d in range(ELIMINATED):
        acc = -b[d]
        for k in range(REDUCED):
            acc += top[d, k] * work[k]
        work[REDUCED + d] = acc
    for k in range(REDUCED):
        b[reduced_column(k)] = work[k]
    if ELIMINATED > 0:  # (pruned where the tracked point is independent: POINT_COLUMNS is then empty)
        for d in range(ELIMINATED):
            b[POINT_COLUMNS[d]] = work[REDUCED + d]


@njit(**NO_REFCOUNT_PYTHON)
def singularity_measure(q, sc, P, lines):
    """The gain-type singularity measure ``S`` at ``q``: zero where the passive motion is undetermined.

    With ``u_i`` the unit direction of the line along which leg ``i`` pushes the platform and ``r_i``
    its attachment point relative to the tracked point (the generated ``leg_lines``):

    * a rigid planar platform on three legs: ``S = det[u_i, r_i × u_i] / ℓ``, zero when the three lines
      meet in a point or are parallel (``ℓ`` the mean distance between attachment points). For an
      equilateral platform this is the paper's eq. (19),
      ``sin(φ1 - α) sin(φ2 - φ3) + sin(φ1 - φ2) sin(α + 2π/3 - φ3)``, ``φ_i`` the angle of ``u_i``;
    * a point on two legs (the five-bar): ``S = sin(φ1 - φ2)``, zero when the distal links align;
    * in space, :func:`spatial_singularity_measure`.

    * any other machine: :func:`passive_determinant`.

    ``sc`` is ``q``'s trig table; ``lines`` an (N_ACTUATORS, LINE_WIDTH) scratch array (N_ACTUATORS >= N_LEGS).
    """
    if not MEASURE_LINES:
        return passive_determinant(q, sc, P, lines)
    leg_lines(q, sc, P, lines)
    if DIM == 3:
        return spatial_singularity_measure(P, lines)
    for i in range(N_LEGS):
        norm = np.sqrt(lines[i, 2] ** 2 + lines[i, 3] ** 2)
        lines[i, 2] /= norm
        lines[i, 3] /= norm
    if N_LEGS == 2:
        return lines[0, 3] * lines[1, 2] - lines[0, 2] * lines[1, 3]
    for i in range(3):  # the moment of each line about the tracked point, in place of r_i
        lines[i, 0] = lines[i, 0] * lines[i, 3] - lines[i, 1] * lines[i, 2]
    det = (lines[0, 2] * (lines[1, 3] * lines[2, 0] - lines[1, 0] * lines[2, 3])
           - lines[0, 3] * (lines[1, 2] * lines[2, 0] - lines[1, 0] * lines[2, 2])
           + lines[0, 0] * (lines[1, 2] * lines[2, 3] - lines[1, 3] * lines[2, 2]))
    return det / platform_size(P)


@njit(**NO_REFCOUNT)
def spatial_singularity_measure(P, lines):
    """``S`` of a spatial machine from its legs' lines (N_ACTUATORS, 6) = ``(r_i, direction_i)`` (overwritten):

    * a translating platform on three legs (the Delta): ``S = det[u_1, u_2, u_3]``, zero when the three
      lines are parallel to one plane (for the Delta's forearms, ``det[P_i - E_i] / L_b³``);
    * a platform with six degrees of freedom on six legs (the Stewart-Gough platform): the determinant
      of the legs' normalised Plücker lines ``[u_i, (r_i × u_i) / ℓ]`` — the 6×6 forward Jacobian of
      the leg lengths — zero when the six lines are linearly dependent (Merlet's line geometry).
    """
    for i in range(N_ACTUATORS):
        norm = np.sqrt(lines[i, 3] ** 2 + lines[i, 4] ** 2 + lines[i, 5] ** 2)
        for k in range(3, 6):
            lines[i, k] /= norm
    if N_ACTUATORS == 3:
        return (lines[0, 3] * (lines[1, 4] * lines[2, 5] - lines[1, 5] * lines[2, 4])
                - lines[0, 4] * (lines[1, 3] * lines[2, 5] - lines[1, 5] * lines[2, 3])
                + lines[0, 5] * (lines[1, 3] * lines[2, 4] - lines[1, 4] * lines[2, 3]))
    size = platform_size(P)
    for i in range(N_ACTUATORS):  # rows [moment / ℓ, u]: a column permutation of [u, moment], same |det|
        rx, ry, rz = lines[i, 0], lines[i, 1], lines[i, 2]
        ux, uy, uz = lines[i, 3], lines[i, 4], lines[i, 5]
        lines[i, 0] = (ry * uz - rz * uy) / size
        lines[i, 1] = (rz * ux - rx * uz) / size
        lines[i, 2] = (rx * uy - ry * ux) / size
    det = -1.0  # three column swaps turn [moment, u] into [u, moment]
    for c in range(N_ACTUATORS):  # Gaussian elimination with partial pivoting, in place
        p = c
        for r in range(c + 1, N_ACTUATORS):
            if abs(lines[r, c]) > abs(lines[p, c]):
                p = r
        if lines[p, c] == 0.0:
            return 0.0
        if p != c:
            det = -det
            for k in range(N_ACTUATORS):
                lines[c, k], lines[p, k] = lines[p, k], lines[c, k]
        det *= lines[c, c]
        for r in range(c + 1, N_ACTUATORS):
            f = lines[r, c] / lines[c, c]
            for k in range(c + 1, N_ACTUATORS):
                lines[r, k] -= f * lines[c, k]
    return det


@njit(**NO_REFCOUNT_INLINE)
def passive_column(i):
    """The column of ``Jηq`` of the i-th dependent coordinate, in the blocks' order where ``Jηφ`` is block diagonal
    (``BLOCKED``)."""
    return dependent_column(reduced_column(i)) if BLOCKED else dependent_column(i)


@njit(**NO_REFCOUNT)
def passive_determinant(q, sc, P, lines):
    """``S`` of a machine whose legs are not two-force members (a 3-PRS, a 3-RPS, a leg of three revolute
    joints…): the determinant of ``Jηφ``, zero exactly where the passive motion is undetermined (the gain-type
    singularities), made dimensionless and independent of how each constraint is written — its columns of
    angles divided by the platform's size ``ℓ`` (they are lever arms, in metres), then each row scaled to unit
    length, so that ``|S| <= 1`` (Hadamard's inequality), 1 when the constraints are orthogonal. ``lines`` is
    the scratch for ``Jηq`` (LINE_WIDTH is chosen so that it holds it)."""
    m = N_CONSTRAINTS
    jac = lines.reshape(-1)[:m * N_COORDINATES].reshape((m, N_COORDINATES))
    constraint_jacobian(q, sc, P, jac)
    size = platform_size(P)
    for r in range(m):
        first, end = (BLOCK_START[r], BLOCK_END[r]) if BLOCKED else (0, m)  # the row's non-zeros
        norm = 0.0
        for i in range(first, end):
            c = passive_column(i)
            if ANGLES[c]:
                jac[r, c] /= size
            norm += jac[r, c] * jac[r, c]
        norm = np.sqrt(norm)
        if norm == 0.0:
            return 0.0
        for i in range(first, end):
            jac[r, passive_column(i)] /= norm
    # Gaussian elimination with partial pivoting on the passive block, in place; a block-diagonal one (BLOCKED) in
    # its blocks' column order, block by block, its determinant that order's times the order's sign
    det = float(REDUCED_SIGN) if BLOCKED else 1.0
    for i in range(m):
        c = passive_column(i)
        end = BLOCK_END[i] if BLOCKED else m
        p = i
        for r in range(i + 1, end):
            if abs(jac[r, c]) > abs(jac[p, c]):
                p = r
        if jac[p, c] == 0.0:
            return 0.0
        if p != i:
            det = -det
            for kk in range(i, end):
                k = passive_column(kk)
                jac[i, k], jac[p, k] = jac[p, k], jac[i, k]
        pivot = jac[i, c]
        det *= pivot
        for r in range(i + 1, end):
            f = jac[r, c] / pivot
            for kk in range(i + 1, end):
                k = passive_column(kk)
                jac[r, k] -= f * jac[i, k]
    return det


@njit(**NO_REFCOUNT)
def factor_passive(ws, q, sc, P):
    """``Jηq`` at ``q`` (trig table ``sc``) into ``ws.j_eta`` and the factors of its passive block ``Jηφ`` (the
    reduced system of :func:`passive_solve`); returns ok (False when ``Jηφ`` is singular)."""
    constraint_jacobian(q, sc, P, ws.j_eta[:])
    for k in range(REDUCED):
        c = dependent_column(reduced_column(k))
        for d in range(ELIMINATED):
            ws.top[d, k] = ws.j_eta[d, c]
        for r in range(REDUCED):
            if ELIMINATED == 0:
                ws.reduced[r, k] = ws.j_eta[r, c]
            else:
                ws.reduced[r, k] = (ws.j_eta[r + ELIMINATED, c]
                                    - (ws.j_eta[r % ELIMINATED, c] if r + ELIMINATED < POINT_ROWS else 0.0))
    if BLOCKED:
        return block_lu_factor(ws.reduced, ws.lu, ws.piv)
    ok, _det = lu_factor(ws.reduced, ws.lu, ws.piv, REDUCED)
    return ok


@njit(**NO_REFCOUNT)
def block_lu_factor(a, lu, piv):
    """:func:`~pkmlab.numerics.closed_chain.lu_factor` of the block-diagonal reduced system (``BLOCKED``), block by
    block: the pivots are sought, and the rows eliminated, within each column's block (``BLOCK_END``) only — the
    same factors as the whole matrix's partial pivoting would give (the other rows hold zeros there), at the cost
    of the blocks. Returns ok."""
    scale = 0.0
    for i in range(REDUCED):
        for j in range(REDUCED):
            lu[i, j] = a[i, j]
            scale = max(scale, abs(a[i, j]))
    for col in range(REDUCED):
        end = BLOCK_END[col]
        p = col
        for row in range(col + 1, end):
            if abs(lu[row, col]) > abs(lu[p, col]):
                p = row
        piv[col] = p
        if abs(lu[p, col]) <= 1e-14 * scale or lu[p, col] == 0.0:
            return False
        if p != col:
            for j in range(REDUCED):
                lu[col, j], lu[p, j] = lu[p, j], lu[col, j]
        inv = 1.0 / lu[col, col]
        for row in range(col + 1, end):
            f = lu[row, col] * inv
            lu[row, col] = f
            for j in range(col + 1, end):
                lu[row, j] -= f * lu[col, j]
        lu[col, col] = inv
    return scale > 0.0


@njit(**NO_REFCOUNT)
def block_lu_solve(lu, piv, b):
    """Overwrite ``b`` (REDUCED,) with the reduced system's solution from the factors of :func:`block_lu_factor`."""
    for col in range(REDUCED):
        p = piv[col]
        if p != col:
            b[col], b[p] = b[p], b[col]
    for col in range(REDUCED):
        for row in range(col + 1, BLOCK_END[col]):
            b[row] -= lu[row, col] * b[col]
    for col in range(REDUCED - 1, -1, -1):
        acc = b[col]
        for c in range(col + 1, BLOCK_END[col]):
            acc -= lu[col, c] * b[c]
        b[col] = acc * lu[col, col]  # the diagonal holds 1 / U_kk


@njit(**NO_REFCOUNT)
def actuated_jacobian(ws, out):
    """``Jqθ = [I; -Jηφ⁻¹ Jηθ]`` (eqs. 15, 31) into ``out`` (N, n) from the last :func:`factor_passive`: the
    identity in the independent coordinates' rows, the dependent coordinates' rates per independent rate in the
    others."""
    n = N_INDEPENDENT
    for j in range(n):
        for i in range(n):
            out[independent_column(i), j] = 1.0 if i == j else 0.0
        for i in range(N_CONSTRAINTS):
            ws.rhs[i] = -ws.j_eta[i, independent_column(j)]
        passive_solve(ws.lu, ws.piv, ws.top, ws.rhs, ws.work)
        for i in range(N_CONSTRAINTS):
            out[dependent_column(i), j] = ws.rhs[i]


@njit(**NO_REFCOUNT)
def correct_passive(ws, q, sc, P):
    """Newton's method on ``η(q) = 0`` for the passive coordinates of ``q`` and its trig table ``sc`` (both in
    place); returns the status."""
    for _ in range(MAX_NEWTON):
        constraints(q, sc, P, ws.eta[:])
        if not factor_passive(ws, q, sc, P):
            return SINGULAR
        passive_solve(ws.lu, ws.piv, ws.top, ws.eta, ws.work)
        step = 0.0
        for i in range(N_CONSTRAINTS):
            step = max(step, abs(ws.eta[i]))
        if not step <= MAX_NEWTON_STEP:  # (NaN included)
            return NOT_CONVERGED
        for i in range(N_CONSTRAINTS):
            q[dependent_column(i)] = settled(q[dependent_column(i)] - ws.eta[i])
        trig_passive(q, sc)
        if step < NEWTON_STEP:
            return OK
    return NOT_CONVERGED


@njit(**NO_REFCOUNT)
def keep_base_factors(ws):
    """The factors just computed (``ws.lu``, ``ws.piv``, ``ws.j_q_theta``) are the base's: keep them for
    branch following from the base."""
    for i in range(REDUCED):
        ws.piv_base[i] = ws.piv[i]
        for d in range(ELIMINATED):
            ws.top_base[d, i] = ws.top[d, i]
        for j in range(REDUCED):
            ws.lu_base[i, j] = ws.lu[i, j]
    for i in range(N_COORDINATES):
        for j in range(N_INDEPENDENT):
            ws.j_q_theta_base[i, j] = ws.j_q_theta[i, j]
    ws.base_factored[0] = 1


@njit(**NO_REFCOUNT_INLINE)
def predict(ws, theta):
    """The first-order predictor of :func:`follow_branch`: ``q[TRIAL] = q[BASE] + Jqθ(base) Δθ`` with
    ``Δθ = ws.step``, the independent coordinates set to ``theta``, and its trig table."""
    base, trial = ws.q[BASE], ws.q[TRIAL]
    for i in range(N_COORDINATES):
        acc = base[i]
        for j in range(N_INDEPENDENT):
            acc += ws.j_q_theta_base[i, j] * ws.step[j]
        trial[i] = acc
    for j in range(N_INDEPENDENT):
        trial[independent_column(j)] = theta[j]
    trig(trial, ws.sc[TRIAL])


@njit(**NO_REFCOUNT)
def follow_branch(ws, theta, P, singularity_guard):
    """The configuration at actuators ``theta`` continuously connected to the base (paper §3.2), into
    ``ws.q[TRIAL]``: a first-order predictor along ``Jφθ`` (eq. 15) from the base, then the chord method
    with the base's ``Jηφ`` (Newton's method if that is slow to converge).

    Fails (``SINGULAR``) when ``|S|`` falls below ``singularity_guard`` or changes sign on the way — the step
    would have crossed a gain-type singularity into another assembly mode; ``NOT_CONVERGED`` when the
    passive coordinates cannot be found near the prediction (the step is too large: take smaller ones,
    :func:`follow_branch_in_steps`). An actuator angle given across ±π from the base's is stepped the
    shorter way round.
    """
    n = N_INDEPENDENT
    base = ws.q[BASE]
    trial, sc = ws.q[TRIAL], ws.sc[TRIAL]
    if ws.base_factored[0] == 0:
        if not factor_passive(ws, base, ws.sc[BASE], P):
            return SINGULAR
        actuated_jacobian(ws, ws.j_q_theta)
        keep_base_factors(ws)
    for j in range(n):
        d = theta[j] - base[independent_column(j)]
        if ANGLES[independent_column(j)]:  # an angle given across ±π: the step the shorter way round (exact if not)
            if d > np.pi:
                d -= 2.0 * np.pi
            elif d < -np.pi:
                d += 2.0 * np.pi
        ws.step[j] = d
    predict(ws, theta)
    status = NOT_CONVERGED
    previous = np.inf
    for _ in range(MAX_CHORD):
        constraints(trial, sc, P, ws.eta[:])
        passive_solve(ws.lu_base, ws.piv_base, ws.top_base, ws.eta, ws.work)
        step = 0.0
        for i in range(N_CONSTRAINTS):
            trial[dependent_column(i)] = settled(trial[dependent_column(i)] - ws.eta[i])
            step = max(step, abs(ws.eta[i]))
        trig_passive(trial, sc)
        # the chord method converges linearly with the ratio of successive steps, r: what remains after
        # this step is at most step r / (1 - r)
        ratio = step / previous  # 0 at the first step: no estimate yet
        if step < NEWTON_STEP or (0.0 < ratio < 0.5 and step * ratio < 0.5 * NEWTON_STEP):
            status = OK
            break
        if not ratio < 1.0:  # not contracting (or NaN): leave it to Newton's method, from the predictor
            break
        previous = step
    if status != OK:
        predict(ws, theta)
        status = correct_passive(ws, trial, sc, P)
        if status != OK:
            return status
    s = singularity_measure(trial, sc, P, ws.lines[:])
    ws.s[TRIAL] = s
    if abs(s) < singularity_guard or s * ws.s[BASE] < 0.0:
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT_PYTHON)
def accept_trial(ws):
    """The trial configuration becomes the base."""
    for i in range(N_COORDINATES):
        ws.q[BASE, i] = ws.q[TRIAL, i]
        ws.sc[BASE, i, 0] = ws.sc[TRIAL, i, 0]
        ws.sc[BASE, i, 1] = ws.sc[TRIAL, i, 1]
    ws.s[BASE] = ws.s[TRIAL]
    ws.base_factored[0] = 0


@njit(**NO_REFCOUNT_PYTHON)
def set_base(ws, q, P):
    """Start branch following from the configuration ``q`` (on the constraint manifold)."""
    for i in range(N_COORDINATES):
        ws.q[BASE, i] = q[i]
    trig(q, ws.sc[BASE])
    ws.s[BASE] = singularity_measure(q, ws.sc[BASE], P, ws.lines[:])
    ws.base_factored[0] = 0


@njit(**NO_REFCOUNT_INLINE)
def is_base(ws, q):
    """Whether ``q`` is the workspace's base, bit for bit, with its factors kept (:func:`keep_base_factors`): branch
    following from ``q`` may then start from the base as it is."""
    if ws.base_factored[0] == 0:
        return False
    for i in range(N_COORDINATES):
        if ws.q[BASE, i] != q[i]:
            return False
    return True


@njit(**NO_REFCOUNT_PYTHON)
def follow_branch_in_steps(ws, q_previous, theta, P, singularity_guard, max_step):
    """Branch following (paper §3.2) from ``q_previous`` to the actuators ``theta`` for callers that may take
    large steps: the actuators moved in equal sub-steps of at most ``max_step`` (rad or m, > 0; an angle the
    shorter way round, so by at most π), each by :func:`follow_branch`, the whole retried in twice as many
    sub-steps when one fails, six times (up to 64 times as many). The configuration reached is left in
    ``ws.q[BASE]``: the target's on success, else the last one reached. ``q_previous`` must not be a view
    of the workspace. Returns the status; ``SINGULAR`` at once when ``|S|`` is below ``singularity_guard`` at
    ``q_previous``."""
    n = N_INDEPENDENT
    for j in range(n):
        ws.start[j] = q_previous[independent_column(j)]
    largest = 0.0
    for j in range(n):
        largest = max(largest, abs(actuator_error(theta, ws.start, j)))
    if not max_step > 0.0:
        return NOT_CONVERGED
    ratio = largest / max_step
    steps = 1 if ratio <= 1.0 else int(np.ceil(min(ratio, 1e6)))
    status = OK
    for _ in range(7):  # steps, 2 steps, ..., 64 times as many
        set_base(ws, q_previous, P)
        if abs(ws.s[BASE]) < singularity_guard:
            return SINGULAR
        for k in range(1, steps + 1):
            for j in range(n):  # the sub-step's target, on q_previous's side of 2π
                ws.target[j] = ws.start[j] + actuator_error(theta, ws.start, j) * (k / steps)
            status = follow_branch(ws, ws.target[:], P, singularity_guard)
            if status != OK:
                break
            accept_trial(ws)
        if status == OK:
            for j in range(n):  # the independent coordinates as asked (an angle may differ by whole turns)
                ws.q[BASE, independent_column(j)] = theta[j]
            return status
        steps *= 2
    return status
