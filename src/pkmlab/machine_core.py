"""The compiled core of every described mechanism: branch following, actuator-space dynamics,
the controller and the sampled-data loop — written once, for any structure.

This module is a *template*. :mod:`pkmlab.derivations.planar` appends the text below the
``TEMPLATE`` marker to every structure's generated kernel module, where the names it uses
(``constraints``, ``constraint_jacobian``, ``body_jacobians``, ``N_COORDINATES``, …) are that
structure's generated code. Each structure thus gets its own compiled loop, bound to its own
kernels at compile time and cached on disk like any other module (Numba's cache cannot hold a
loop that receives kernels as arguments: each process would compile it again). The
generated text is checked to be current by the test suite, so this file is the one source.

Conventions (as in the generated kernels): ``q = (θ, φ)`` with the ``n`` actuator values ``θ``
first and the passive coordinates ``φ`` (the passive joints, then the pose) after them;
``η(q) = 0`` are the ``m = len(φ)`` loop-closure equations; ``P`` is the packed parameter vector.
Every generated kernel reads the angles' cosines and sines from a trig table ``sc`` (N, 2) of its
configuration (``trig``), computed once per configuration and shared by every kernel evaluated there.
Every function is allocation-free and works in a :class:`Workspace`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what a structure's generated module defines before the template's text
    from .mechanisms.generated.planar_RaRR_RaRR_RaRR_rigid import (  # noqa: F401
        ANGLES,
        ANGULAR,
        BODY_ROWS,
        DIM,
        DOF,
        GRAVITY_INDEX,
        INERTIA_INDEX,
        JB_BODY,
        JB_COL,
        JB_ROW,
        LINE_WIDTH,
        MASS_INDEX,
        N_ACTUATORS,
        N_BODIES,
        N_CONSTRAINTS,
        N_COORDINATES,
        N_JB,
        body_bias,
        body_jacobian_values,
        constraint_bias,
        constraint_jacobian,
        constraints,
        leg_lines,
        platform_size,
        trig,
        trig_passive,
    )

# ==== TEMPLATE: the text from here on is appended to every generated kernel module ====
import numpy as np  # noqa: E402

from pkmlab._compile_cache import INTERPRETED, NO_REFCOUNT, NO_REFCOUNT_INLINE, njit, prange  # noqa: E402
from pkmlab.closed_chain import (  # noqa: E402
    ldlt_solve,
    lu_factor,
    lu_solve_factored,
)

#: Status codes of the compiled functions (as :mod:`pkmlab.mechanisms.rrr3`'s).
OK = 0
NOT_CONVERGED = 1  # Newton's method did not converge (no nearby configuration)
SINGULAR = 2  # |S| fell below the guard, S changed sign, or a matrix was singular
CONTROLLER = 10  # added to a status of the controller's own model

#: Newton's method on the passive coordinates: at most this many iterations, stopping when a
#: step is below NEWTON_STEP (metres or radians; convergence is quadratic, so the residual is
#: then at round-off).
MAX_NEWTON = 12
NEWTON_STEP = 1e-13
#: A Newton step longer than this (m or rad) means the iteration is heading for another solution (another
#: assembly mode, or the same one whole turns away): refused, so that the caller takes a smaller step.
MAX_NEWTON_STEP = 1.0
#: Branch following first iterates with the base's Jacobian (the chord method: no Jacobian to
#: evaluate or factor per iteration; it contracts by about the step's size in the actuators, so a
#: sample's step converges in 2-4 iterations), and falls back to Newton's method after this many.
MAX_CHORD = 8


@njit(cache=True)
def singularity_measures(qs, P, out):
    """:func:`singularity_measure` of every configuration ``qs`` (K, N) into ``out`` (K,); NaN rows give NaN."""
    lines, sc = np.empty((N_ACTUATORS, LINE_WIDTH)), np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        out[k] = singularity_measure(qs[k], sc, P, lines)


@njit(cache=True)
def constraint_jacobians(qs, P, out):
    """``Jηq`` of every configuration ``qs`` (K, N) into ``out`` (K, m, N)."""
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        constraint_jacobian(qs[k], sc, P, out[k])


@njit(cache=True)
def constraint_biases(qs, q_dots, P, out):
    """``J̇ηq q̇`` of every configuration and rate (K, N) into ``out`` (K, m)."""
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        constraint_bias(qs[k], sc, q_dots[k], P, out[k])


BASE = 0
TRIAL = 1

# Every leg closes on the platform by DIM equations (2 in the plane, 3 in space) whose derivatives with
# respect to the tracked point (x, y[, z]) are minus the identity (η = end of the leg's chain - attachment
# point): eliminating the tracked point with these unit pivots leaves a system of DIM equations fewer in
# the other passive coordinates (the passive joints and the orientation), to be factored instead of the
# whole of Jηφ. X_COLUMN is x's column in Jηφ.
REDUCED = N_CONSTRAINTS - DIM
X_COLUMN = N_CONSTRAINTS - DOF


#: One model's evaluations work in a *workspace*: a record of this type holding every scratch array
#: (``q[BASE]`` is the base configuration — the last accepted one, from which branch following starts —
#: and ``q[TRIAL]`` a trial configuration). A record is passed to a function by a single pointer and its
#: arrays have shapes known at compile time; a tuple of ~30 arrays was copied, array by array, into
#: every call that took it (which cost about a quarter of the simulation loop's time).
WORKSPACE = np.dtype([
    ("q", np.float64, (2, N_COORDINATES)),  # base and trial configurations
    ("sc", np.float64, (2, N_COORDINATES, 2)),  # their trig tables
    ("s", np.float64, (2,)),  # their singularity measures
    ("j_eta", np.float64, (N_CONSTRAINTS, N_COORDINATES)),  # Jηq
    ("lu", np.float64, (REDUCED, REDUCED)),  # factors of Jηφ's reduced system (the tracked point eliminated)
    ("piv", np.int64, (REDUCED,)),
    ("eta", np.float64, (N_CONSTRAINTS,)),
    ("j_q_theta", np.float64, (N_COORDINATES, N_ACTUATORS)),  # Jqθ (eq. 31)
    ("q_dot", np.float64, (N_COORDINATES,)),
    ("bias_q", np.float64, (N_COORDINATES,)),  # J̇qθ θ̇ (eq. 32)
    ("gamma", np.float64, (N_CONSTRAINTS,)),  # J̇ηq q̇
    ("jb", np.float64, (N_JB,)),  # the non-zeros of the bodies' Jacobians
    ("bb", np.float64, (N_BODIES, BODY_ROWS)),  # bodies' J̇ q̇, then their accelerations at θ̈ = 0
    ("jt", np.float64, (N_BODIES, BODY_ROWS, N_ACTUATORS)),  # the bodies' Jacobians times Jqθ
    ("m_theta", np.float64, (N_ACTUATORS, N_ACTUATORS)),  # Mθ
    ("c_theta", np.float64, (N_ACTUATORS,)),  # cθ = Cθ θ̇
    ("g_theta", np.float64, (N_ACTUATORS,)),  # gθ = ∂V/∂θ
    ("theta_ddot", np.float64, (N_ACTUATORS,)),
    ("ldl", np.float64, (N_ACTUATORS, N_ACTUATORS)),  # factor of Mθ
    ("lines", np.float64, (N_ACTUATORS, LINE_WIDTH)),  # the legs' lines of action
    ("lu_base", np.float64, (REDUCED, REDUCED)),  # the same factors at the base, kept for branch following from it
    ("piv_base", np.int64, (REDUCED,)),
    ("j_q_theta_base", np.float64, (N_COORDINATES, N_ACTUATORS)),  # Jqθ at the base
    ("base_factored", np.int64, (1,)),  # 1 when the three above are the base's
    ("top", np.float64, (DIM, REDUCED)),  # rows 0 .. DIM - 1 of Jηφ in the reduced system's columns
    ("top_base", np.float64, (DIM, REDUCED)),  # the same at the base
    ("reduced", np.float64, (REDUCED, REDUCED)),  # the reduced system before factoring
    ("work", np.float64, (N_CONSTRAINTS,)),  # the reduced system's right-hand side, then the tracked point's DIM values
    ("rhs", np.float64, (N_CONSTRAINTS,)),
    ("target", np.float64, (N_ACTUATORS,)),  # the actuators of a sub-step of follow_branch_in_steps
    ("step", np.float64, (N_ACTUATORS,)),  # the actuators' step of follow_branch's predictor
], align=True)


@njit(cache=True)
def make_workspaces(count):
    """``count`` workspaces, a record array; a kernel takes one record (``workspaces[k]``), and the array must
    outlive every use of it (so entry points allocate it and pass it to the function that does the work)."""
    return np.zeros(count, WORKSPACE)


if INTERPRETED:  # the kernels read a record's arrays by attribute (ws.q): a record array of NumPy's that does
    _workspace_records = make_workspaces

    def make_workspaces(count):  # noqa: F811
        return _workspace_records(count).view(np.recarray)


@njit(**NO_REFCOUNT_INLINE)
def reduced_column(k):
    """The column of Jηφ of the k-th coordinate of the reduced system (the tracked point skipped)."""
    return k if k < X_COLUMN else k + DIM


@njit(**NO_REFCOUNT)
def passive_solve(lu, piv, top, b, work):
    """Overwrite ``b`` (m,) with ``Jηφ⁻¹ b`` from the factors of the reduced system (:func:`factor_passive`):
    its rows are the constraints' rows DIM.. minus row 0 (x), 1 (y) or 2 (z), free of the tracked point;
    then the tracked point from rows 0 .. DIM - 1 (``top``: their entries in the reduced system's columns).
    ``work`` is an (m,) scratch array."""
    for r in range(REDUCED):
        work[r] = b[r + DIM] - b[r % DIM]
    lu_solve_factored(lu, piv, work, REDUCED)
    for d in range(DIM):
        acc = -b[d]
        for k in range(REDUCED):
            acc += top[d, k] * work[k]
        work[REDUCED + d] = acc
    for k in range(REDUCED):
        b[reduced_column(k)] = work[k]
    for d in range(DIM):
        b[X_COLUMN + d] = work[REDUCED + d]


@njit(**NO_REFCOUNT)
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

    ``sc`` is ``q``'s trig table; ``lines`` an (N_ACTUATORS, LINE_WIDTH) scratch array.
    """
    leg_lines(q, sc, P, lines)
    if DIM == 3:
        return spatial_singularity_measure(P, lines)
    for i in range(N_ACTUATORS):
        norm = np.sqrt(lines[i, 2] ** 2 + lines[i, 3] ** 2)
        lines[i, 2] /= norm
        lines[i, 3] /= norm
    if N_ACTUATORS == 2:
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


@njit(**NO_REFCOUNT)
def factor_passive(ws, q, sc, P):
    """``Jηq`` at ``q`` (trig table ``sc``) into ``ws.j_eta`` and the factors of its passive block ``Jηφ`` (the
    reduced system of :func:`passive_solve`); returns ok (False when ``Jηφ`` is singular)."""
    constraint_jacobian(q, sc, P, ws.j_eta)
    n = N_ACTUATORS
    for k in range(REDUCED):
        c = n + reduced_column(k)
        for d in range(DIM):
            ws.top[d, k] = ws.j_eta[d, c]
        for r in range(REDUCED):
            ws.reduced[r, k] = ws.j_eta[r + DIM, c] - ws.j_eta[r % DIM, c]
    ok, _det = lu_factor(ws.reduced, ws.lu, ws.piv, REDUCED)
    return ok


@njit(**NO_REFCOUNT)
def actuated_jacobian(ws, out):
    """``Jqθ = [I; -Jηφ⁻¹ Jηθ]`` (eqs. 15, 31) into ``out`` (N, n) from the last :func:`factor_passive`."""
    n = N_ACTUATORS
    for j in range(n):
        for i in range(n):
            out[i, j] = 1.0 if i == j else 0.0
        for i in range(N_CONSTRAINTS):
            ws.rhs[i] = -ws.j_eta[i, j]
        passive_solve(ws.lu, ws.piv, ws.top, ws.rhs, ws.work)
        for i in range(N_CONSTRAINTS):
            out[n + i, j] = ws.rhs[i]


@njit(**NO_REFCOUNT)
def correct_passive(ws, q, sc, P):
    """Newton's method on ``η(q) = 0`` for the passive coordinates of ``q`` and its trig table ``sc`` (both in
    place); returns the status."""
    n = N_ACTUATORS
    for _ in range(MAX_NEWTON):
        constraints(q, sc, P, ws.eta)
        if not factor_passive(ws, q, sc, P):
            return SINGULAR
        passive_solve(ws.lu, ws.piv, ws.top, ws.eta, ws.work)
        step = 0.0
        for i in range(N_CONSTRAINTS):
            step = max(step, abs(ws.eta[i]))
        if not step <= MAX_NEWTON_STEP:  # (NaN included)
            return NOT_CONVERGED
        for i in range(N_CONSTRAINTS):
            q[n + i] -= ws.eta[i]
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
        for d in range(DIM):
            ws.top_base[d, i] = ws.top[d, i]
        for j in range(REDUCED):
            ws.lu_base[i, j] = ws.lu[i, j]
    for i in range(N_COORDINATES):
        for j in range(N_ACTUATORS):
            ws.j_q_theta_base[i, j] = ws.j_q_theta[i, j]
    ws.base_factored[0] = 1


@njit(**NO_REFCOUNT_INLINE)
def predict(ws, theta):
    """The first-order predictor of :func:`follow_branch`: ``q[TRIAL] = q[BASE] + Jqθ(base) Δθ`` with
    ``Δθ = ws.step``, the actuators set to ``theta``, and its trig table."""
    base, trial = ws.q[BASE], ws.q[TRIAL]
    for i in range(N_COORDINATES):
        acc = base[i]
        for j in range(N_ACTUATORS):
            acc += ws.j_q_theta_base[i, j] * ws.step[j]
        trial[i] = acc
    for j in range(N_ACTUATORS):
        trial[j] = theta[j]
    trig(trial, ws.sc[TRIAL])


@njit(**NO_REFCOUNT)
def follow_branch(ws, theta, P, min_abs_s):
    """The configuration at actuators ``theta`` continuously connected to the base (paper §3.2), into
    ``ws.q[TRIAL]``: a first-order predictor along ``Jφθ`` (eq. 15) from the base, then the chord method
    with the base's ``Jηφ`` (Newton's method if that is slow to converge).

    Fails (``SINGULAR``) when ``|S|`` falls below ``min_abs_s`` or changes sign on the way — the step
    would have crossed a gain-type singularity into another assembly mode; ``NOT_CONVERGED`` when the
    passive coordinates cannot be found near the prediction (the step is too large: take smaller ones,
    :func:`follow_branch_in_steps`). An actuator angle given across ±π from the base's is stepped the
    shorter way round.
    """
    n = N_ACTUATORS
    base = ws.q[BASE]
    trial, sc = ws.q[TRIAL], ws.sc[TRIAL]
    if ws.base_factored[0] == 0:
        if not factor_passive(ws, base, ws.sc[BASE], P):
            return SINGULAR
        actuated_jacobian(ws, ws.j_q_theta)
        keep_base_factors(ws)
    for j in range(n):
        d = theta[j] - base[j]
        if ANGLES[j]:  # an angle given across ±π: the step the shorter way round (exact when it is not)
            if d > np.pi:
                d -= 2.0 * np.pi
            elif d < -np.pi:
                d += 2.0 * np.pi
        ws.step[j] = d
    predict(ws, theta)
    status = NOT_CONVERGED
    previous = np.inf
    for _ in range(MAX_CHORD):
        constraints(trial, sc, P, ws.eta)
        passive_solve(ws.lu_base, ws.piv_base, ws.top_base, ws.eta, ws.work)
        step = 0.0
        for i in range(N_CONSTRAINTS):
            trial[n + i] -= ws.eta[i]
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
    s = singularity_measure(trial, sc, P, ws.lines)
    ws.s[TRIAL] = s
    if abs(s) < min_abs_s or s * ws.s[BASE] < 0.0:
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT)
def accept_trial(ws):
    """The trial configuration becomes the base."""
    for i in range(N_COORDINATES):
        ws.q[BASE, i] = ws.q[TRIAL, i]
        ws.sc[BASE, i, 0] = ws.sc[TRIAL, i, 0]
        ws.sc[BASE, i, 1] = ws.sc[TRIAL, i, 1]
    ws.s[BASE] = ws.s[TRIAL]
    ws.base_factored[0] = 0


@njit(**NO_REFCOUNT)
def set_base(ws, q, P):
    """Start branch following from the configuration ``q`` (on the constraint manifold)."""
    for i in range(N_COORDINATES):
        ws.q[BASE, i] = q[i]
    trig(q, ws.sc[BASE])
    ws.s[BASE] = singularity_measure(q, ws.sc[BASE], P, ws.lines)
    ws.base_factored[0] = 0


@njit(**NO_REFCOUNT)
def follow_branch_in_steps(ws, q_previous, theta, P, min_abs_s, max_step):
    """Branch following (paper §3.2) from ``q_previous`` to the actuators ``theta`` for callers that may take
    large steps: the actuators moved in equal sub-steps of at most ``max_step`` (rad or m, > 0; an angle the
    shorter way round, so by at most π), each by :func:`follow_branch`, the whole retried in twice as many
    sub-steps when one fails, six times (up to 64 times as many). The configuration reached is left in
    ``ws.q[BASE]``: the target's on success, else the last one reached. ``q_previous`` must not be a view
    of the workspace. Returns the status; ``SINGULAR`` at once when ``|S|`` is below ``min_abs_s`` at
    ``q_previous``."""
    n = N_ACTUATORS
    largest = 0.0
    for j in range(n):
        largest = max(largest, abs(actuator_error(theta, q_previous, j)))
    if not max_step > 0.0:
        return NOT_CONVERGED
    ratio = largest / max_step
    steps = 1 if ratio <= 1.0 else int(np.ceil(min(ratio, 1e6)))
    status = OK
    for _ in range(7):  # steps, 2 steps, ..., 64 times as many
        set_base(ws, q_previous, P)
        if abs(ws.s[BASE]) < min_abs_s:
            return SINGULAR
        for k in range(1, steps + 1):
            for j in range(n):  # the sub-step's target, on q_previous's side of 2π
                ws.target[j] = q_previous[j] + actuator_error(theta, q_previous, j) * (k / steps)
            status = follow_branch(ws, ws.target, P, min_abs_s)
            if status != OK:
                break
            accept_trial(ws)
        if status == OK:
            for j in range(n):  # the actuators as asked (an angle may differ by whole turns)
                ws.q[BASE, j] = theta[j]
            return status
        steps *= 2
    return status


@njit(**NO_REFCOUNT)
def actuator_space_model(ws, q, sc, theta_dot, P):
    """``Mθ``, ``cθ = Cθ θ̇`` and ``gθ = ∂V/∂θ`` of ``Mθ θ̈ + cθ + gθ = τ`` (eq. 35, with gravity) at ``q``
    on the manifold (trig table ``sc``), into ``ws.m_theta``, ``ws.c_theta``, ``ws.g_theta``; returns ok
    (``det Jηφ ≠ 0``).

    Body by body, with ``Jt = J_b Jqθ`` the body's velocity per actuator rate and
    ``a_b = J_b J̇qθ θ̇ + J̇_b q̇`` its acceleration at ``θ̈ = 0``:
    ``Mθ = Σ Jtᵀ D_b Jt``, ``cθ = Σ Jtᵀ D_b a_b``, ``gθ = -Σ m_b Jt_linᵀ g`` (``D_b = diag(m, m, I)``; in
    space :func:`spatial_body_sums`).
    """
    n, N = N_ACTUATORS, N_COORDINATES
    if not factor_passive(ws, q, sc, P):
        return False
    actuated_jacobian(ws, ws.j_q_theta)
    for i in range(N):
        acc = 0.0
        for j in range(n):
            acc += ws.j_q_theta[i, j] * theta_dot[j]
        ws.q_dot[i] = acc
    constraint_bias(q, sc, ws.q_dot, P, ws.gamma)
    for k in range(N_CONSTRAINTS):  # φ̈ at θ̈ = 0: -Jηφ⁻¹ J̇ηq q̇ (eq. 32)
        ws.gamma[k] = -ws.gamma[k]
    passive_solve(ws.lu, ws.piv, ws.top, ws.gamma, ws.work)
    for i in range(n):
        ws.bias_q[i] = 0.0
    for k in range(N_CONSTRAINTS):
        ws.bias_q[n + k] = ws.gamma[k]
    body_jacobian_values(q, sc, P, ws.jb)
    body_bias(q, sc, ws.q_dot, P, ws.bb)
    for b in range(N_BODIES):
        for r in range(BODY_ROWS):
            for j in range(n):
                ws.jt[b, r, j] = 0.0
    for z in range(N_JB):  # Jt = J_b Jqθ and a_b += J_b J̇qθ θ̇ over the non-zeros of J_b only
        b, r, k, v = JB_BODY[z], JB_ROW[z], JB_COL[z], ws.jb[z]
        for j in range(n):
            ws.jt[b, r, j] += v * ws.j_q_theta[k, j]
        ws.bb[b, r] += v * ws.bias_q[k]
    if ANGULAR == 3:
        spatial_body_sums(ws, theta_dot, P)
        return True
    gx, gy = P[GRAVITY_INDEX[0]], P[GRAVITY_INDEX[1]]
    # each entry summed in a register and stored once (accumulating into the workspace's arrays would
    # load and store at every term: the compiler cannot rule out that they overlap)
    for i in range(n):
        c, g = 0.0, 0.0
        for b in range(N_BODIES):
            mass, inertia = P[MASS_INDEX[b]], P[INERTIA_INDEX[b]]
            c += (mass * (ws.jt[b, 0, i] * ws.bb[b, 0] + ws.jt[b, 1, i] * ws.bb[b, 1])
                  + inertia * ws.jt[b, 2, i] * ws.bb[b, 2])
            g -= mass * (ws.jt[b, 0, i] * gx + ws.jt[b, 1, i] * gy)
        ws.c_theta[i] = c
        ws.g_theta[i] = g
        for j in range(i, n):
            acc = 0.0
            for b in range(N_BODIES):
                mass, inertia = P[MASS_INDEX[b]], P[INERTIA_INDEX[b]]
                acc += (mass * (ws.jt[b, 0, i] * ws.jt[b, 0, j] + ws.jt[b, 1, i] * ws.jt[b, 1, j])
                        + inertia * ws.jt[b, 2, i] * ws.jt[b, 2, j])
            ws.m_theta[i, j] = acc
            ws.m_theta[j, i] = acc
    return True


@njit(**NO_REFCOUNT)
def spatial_body_sums(ws, theta_dot, P):
    """The body sums of :func:`actuator_space_model` for spatial bodies, whose Jacobian rows are the mass
    centre's velocity (3) and the angular velocity in the body's own frame ``ω`` (3), with the inertia
    tensor ``I`` about the mass centre in that frame (6 parameters from ``INERTIA_INDEX``: xx, yy, zz,
    xy, xz, yz): Newton–Euler projected on the actuators,
    ``Mθ = Σ m Jt_vᵀ Jt_v + Jt_ωᵀ I Jt_ω``, ``cθ = Σ m Jt_vᵀ a_v + Jt_ωᵀ (I a_ω + ω × I ω)``,
    ``gθ = -Σ m Jt_vᵀ g``. The gyroscopic term ``ω × I ω`` is what a planar body never has."""
    n = N_ACTUATORS
    for b in range(N_BODIES):  # the angular rows of bb become I a_ω + ω × I ω
        k = INERTIA_INDEX[b]
        ixx, iyy, izz, ixy, ixz, iyz = P[k], P[k + 1], P[k + 2], P[k + 3], P[k + 4], P[k + 5]
        wx, wy, wz = 0.0, 0.0, 0.0
        for j in range(n):
            wx += ws.jt[b, 3, j] * theta_dot[j]
            wy += ws.jt[b, 4, j] * theta_dot[j]
            wz += ws.jt[b, 5, j] * theta_dot[j]
        hx = ixx * wx + ixy * wy + ixz * wz
        hy = ixy * wx + iyy * wy + iyz * wz
        hz = ixz * wx + iyz * wy + izz * wz
        ax, ay, az = ws.bb[b, 3], ws.bb[b, 4], ws.bb[b, 5]
        ws.bb[b, 3] = ixx * ax + ixy * ay + ixz * az + (wy * hz - wz * hy)
        ws.bb[b, 4] = ixy * ax + iyy * ay + iyz * az + (wz * hx - wx * hz)
        ws.bb[b, 5] = ixz * ax + iyz * ay + izz * az + (wx * hy - wy * hx)
    for i in range(n):
        c, g = 0.0, 0.0
        for b in range(N_BODIES):
            mass = P[MASS_INDEX[b]]
            c += (mass * (ws.jt[b, 0, i] * ws.bb[b, 0] + ws.jt[b, 1, i] * ws.bb[b, 1] + ws.jt[b, 2, i] * ws.bb[b, 2])
                  + ws.jt[b, 3, i] * ws.bb[b, 3] + ws.jt[b, 4, i] * ws.bb[b, 4] + ws.jt[b, 5, i] * ws.bb[b, 5])
            for d in range(DIM):
                g -= mass * ws.jt[b, d, i] * P[GRAVITY_INDEX[d]]
        ws.c_theta[i] = c
        ws.g_theta[i] = g
        for j in range(i, n):
            acc = 0.0
            for b in range(N_BODIES):
                mass, k = P[MASS_INDEX[b]], INERTIA_INDEX[b]
                ixx, iyy, izz, ixy, ixz, iyz = P[k], P[k + 1], P[k + 2], P[k + 3], P[k + 4], P[k + 5]
                ux, uy, uz = ws.jt[b, 3, j], ws.jt[b, 4, j], ws.jt[b, 5, j]
                acc += (mass * (ws.jt[b, 0, i] * ws.jt[b, 0, j] + ws.jt[b, 1, i] * ws.jt[b, 1, j]
                                + ws.jt[b, 2, i] * ws.jt[b, 2, j])
                        + ws.jt[b, 3, i] * (ixx * ux + ixy * uy + ixz * uz)
                        + ws.jt[b, 4, i] * (ixy * ux + iyy * uy + iyz * uz)
                        + ws.jt[b, 5, i] * (ixz * ux + iyz * uy + izz * uz))
            ws.m_theta[i, j] = acc
            ws.m_theta[j, i] = acc


@njit(cache=True)
def actuator_space_models(qs, theta_dots, P, m_out, c_out, g_out):
    """:func:`actuator_space_model` of every configuration ``qs`` (K, N) and rates ``theta_dots`` (K, n) into
    ``m_out`` (K, n, n), ``c_out`` and ``g_out`` (K, n); returns the first singular one's index, or -1."""
    return _actuator_space_models(make_workspaces(1), qs, theta_dots, P, m_out, c_out, g_out)


@njit(cache=True)
def _actuator_space_models(workspaces, qs, theta_dots, P, m_out, c_out, g_out):
    ws = workspaces[0]
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        if not actuator_space_model(ws, qs[k], sc, theta_dots[k], P):
            return k
        m_out[k] = ws.m_theta
        c_out[k] = ws.c_theta
        g_out[k] = ws.g_theta
    return -1


@njit(**NO_REFCOUNT)
def solve_accelerations(ws, tau):
    """``θ̈ = Mθ⁻¹ (τ - cθ - gθ)`` into ``ws.theta_ddot`` from the last :func:`actuator_space_model`."""
    for i in range(N_ACTUATORS):
        ws.theta_ddot[i] = tau[i] - ws.c_theta[i] - ws.g_theta[i]
    return ldlt_solve(ws.m_theta, ws.ldl, ws.theta_ddot)


@njit(**NO_REFCOUNT)
def plant_stage(ws, theta, theta_dot, tau, P, min_abs_s, slot, known):
    """``θ̈`` of the reduced plant at ``(θ, θ̇)`` into ``ws.theta_ddot``; returns the status.

    ``slot = BASE``: ``θ`` is the base's own; otherwise the passive coordinates are first found by
    branch following from the base. ``known``: the workspace already holds the model there
    (:func:`actuator_space_model` at the base and ``θ̇``, see :func:`copy_model`).
    """
    if slot != BASE:
        status = follow_branch(ws, theta, P, min_abs_s)
        if status != OK:
            return status
    if not known and not actuator_space_model(ws, ws.q[slot], ws.sc[slot], theta_dot, P):
        return SINGULAR
    if slot == BASE:
        keep_base_factors(ws)
    if not solve_accelerations(ws, tau):
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT)
def actuator_error(theta, theta_d, i):
    """``θ_i - θ_d,i``, wrapped to ``(-π, π]`` for an angle (a revolute actuator)."""
    e = theta[i] - theta_d[i]
    if ANGLES[i]:
        e = (e + np.pi) % (2.0 * np.pi) - np.pi
    return e


@njit(**NO_REFCOUNT)
def control_effort(kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, min_abs_s, ws, tau):
    """Efforts ``τ`` of one controller evaluation into ``tau``; returns the status.

    ``kind = 0``, computed torque (eqs. 36–39 with gravity): ``τ = M̂θ v + ĉθ + ĝθ``,
    ``v = θ̈_d - kp e - kv ė``, with the controller's own model (parameters ``P``, workspace ``ws``),
    whose passive coordinates follow the measured ``θ`` by branch following (paper figure 2).
    ``kind = 1``, PD: ``τ = -kp e - kv ė``.
    """
    n = N_ACTUATORS
    if kind == 1:
        for i in range(n):
            tau[i] = -kp * actuator_error(theta, theta_d, i) - kv * (theta_dot[i] - theta_dot_d[i])
        return OK
    status = follow_branch(ws, theta, P, min_abs_s)
    if status != OK:
        return status
    accept_trial(ws)
    return computed_torque(kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau)


@njit(**NO_REFCOUNT)
def computed_torque(kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau):
    """The computed-torque law of :func:`control_effort` with the controller's model already at the measured
    ``theta`` (``ws.q[BASE]``); returns the status."""
    n = N_ACTUATORS
    if not actuator_space_model(ws, ws.q[BASE], ws.sc[BASE], theta_dot, P):
        return SINGULAR
    keep_base_factors(ws)
    for i in range(n):  # v, kept in theta_ddot
        ws.theta_ddot[i] = (theta_ddot_d[i] - kp * actuator_error(theta, theta_d, i)
                            - kv * (theta_dot[i] - theta_dot_d[i]))
    for i in range(n):
        acc = ws.c_theta[i] + ws.g_theta[i]
        for j in range(n):
            acc += ws.m_theta[i, j] * ws.theta_ddot[j]
        tau[i] = acc
    return OK


@njit(**NO_REFCOUNT)
def copy_base(source, destination):
    """The base configuration of the workspace ``source`` (configuration, trig table, ``S``) made
    ``destination``'s: for two workspaces of the same machine."""
    for i in range(N_COORDINATES):
        destination.q[BASE, i] = source.q[BASE, i]
        destination.sc[BASE, i, 0] = source.sc[BASE, i, 0]
        destination.sc[BASE, i, 1] = source.sc[BASE, i, 1]
    destination.s[BASE] = source.s[BASE]
    destination.base_factored[0] = 0


@njit(**NO_REFCOUNT)
def copy_model(source, destination):
    """The model evaluated at the base (``Mθ``, ``cθ``, ``gθ``, ``Jqθ`` and the factors of ``Jηφ``) copied from
    the workspace ``source`` to ``destination``: for two workspaces of the same machine at the same base
    configuration and rates."""
    for i in range(N_COORDINATES):
        for j in range(N_ACTUATORS):
            destination.j_q_theta[i, j] = source.j_q_theta[i, j]
    for i in range(N_ACTUATORS):
        destination.c_theta[i] = source.c_theta[i]
        destination.g_theta[i] = source.g_theta[i]
        for j in range(N_ACTUATORS):
            destination.m_theta[i, j] = source.m_theta[i, j]
    for i in range(REDUCED):
        destination.piv[i] = source.piv[i]
        for d in range(DIM):
            destination.top[d, i] = source.top[d, i]
        for j in range(REDUCED):
            destination.lu[i, j] = source.lu[i, j]


@njit(**NO_REFCOUNT)
def rk4_sample(ws, x, tau, P, dt, n_sub, min_abs_s, work, known):
    """Advance the reduced plant over one sample with constant ``τ``: classical RK4 in ``n_sub`` steps.

    ``x`` (2n,) = ``(θ, θ̇)`` is updated in place and the base configuration moved along; stages
    find their passive coordinates by branch following from the start of the step. ``work`` is a
    (5, 2n) scratch array. ``known``: the workspace already holds the model at the sample's start
    (its first stage). Returns the status.
    """
    n = N_ACTUATORS
    h = dt / n_sub
    k = work[:4]
    y = work[4]
    for step in range(n_sub):
        for stage in range(4):
            c = 0.0 if stage == 0 else (h if stage == 3 else 0.5 * h)
            for i in range(2 * n):
                y[i] = x[i] + c * k[stage - 1, i] if stage > 0 else x[i]
            status = plant_stage(ws, y[:n], y[n:], tau, P, min_abs_s, BASE if stage == 0 else TRIAL,
                                 known and step == 0 and stage == 0)
            if status != OK:
                return status
            for i in range(n):
                k[stage, i] = y[n + i]
                k[stage, n + i] = ws.theta_ddot[i]
        for i in range(2 * n):
            x[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
        status = follow_branch(ws, x[:n], P, min_abs_s)
        if status != OK:
            return status
        accept_trial(ws)
    return OK


@njit(cache=True)
def sampled_data_loop(ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl,
                      kind, kp, kv, min_abs_s, out_q, out_theta_dot, out_tau, out_s):
    """The whole sampled-data run (conventions §5: the effort computed at ``t_k`` is held until ``t_k+1``);
    returns ``(status, k)``, ``k`` the sample of a failure (else -1). A status of the controller's
    own model is offset by ``CONTROLLER``. Records the plant's configuration, rates, efforts and ``S``."""
    return _sampled_data_loop(make_workspaces(2), ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0,
                              P_plant, P_ctrl, kind, kp, kv, min_abs_s, out_q, out_theta_dot, out_tau, out_s)


@njit(cache=True)
def _sampled_data_loop(workspaces, ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant,
                       P_ctrl, kind, kp, kv, min_abs_s, out_q, out_theta_dot, out_tau, out_s):
    n = N_ACTUATORS
    plant, ctrl = workspaces[0], workspaces[1]
    set_base(plant, q_plant0, P_plant)
    set_base(ctrl, q_ctrl0, P_ctrl)
    x = np.zeros(2 * n)
    for i in range(n):
        x[i] = q_plant0[i]
    work = np.empty((5, 2 * n))
    tau = np.zeros(n)
    # a computed-torque controller whose model is the plant (the nominal cases): from the second sample on, its
    # model's configuration at the measured θ is the plant's own (same machine, same branch: the plant's
    # branch following has just reached it and checked its S), and the model it evaluates there is the plant's
    # at the sample's start, the RK4 step's first stage: both taken over instead of computed twice
    same = kind == 0
    for i in range(P_plant.size):
        same = same and P_plant[i] == P_ctrl[i]
    for k in range(theta_d.shape[0]):
        out_q[k] = plant.q[BASE]
        out_s[k] = plant.s[BASE]
        out_theta_dot[k] = x[n:]
        shared = same and k > 0
        if shared:
            copy_base(plant, ctrl)
            status = computed_torque(kp, kv, x[:n], x[n:], theta_d[k], theta_dot_d[k], theta_ddot_d[k], P_ctrl, ctrl,
                                     tau)
        else:
            status = control_effort(kind, kp, kv, x[:n], x[n:], theta_d[k], theta_dot_d[k], theta_ddot_d[k], P_ctrl,
                                    min_abs_s, ctrl, tau)
        if status != OK:
            return CONTROLLER + status, k
        out_tau[k] = tau
        if k == theta_d.shape[0] - 1:
            break
        if shared:
            copy_model(ctrl, plant)
        status = rk4_sample(plant, x, tau, P_plant, ts, n_sub, min_abs_s, work, shared)
        if status != OK:
            return status, k
    return OK, -1


@njit(cache=True, parallel=True)
def sampled_data_batch(ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl, kind,
                       kp, kv, min_abs_s, out_q, out_theta_dot, out_tau, out_s, out_status, out_k):
    """:func:`sampled_data_loop` for a batch of runs (leading axis) over the CPU cores; each run executes
    exactly the code of a single run."""
    for r in prange(theta_d.shape[0]):
        status, k = sampled_data_loop(ts[r], n_sub[r], theta_d[r], theta_dot_d[r], theta_ddot_d[r], q_plant0[r],
                                      q_ctrl0[r], P_plant[r], P_ctrl[r], kind[r], kp[r], kv[r], min_abs_s[r],
                                      out_q[r], out_theta_dot[r], out_tau[r], out_s[r])
        out_status[r] = status
        out_k[r] = k


# ---- entry points for callers outside compiled code (an adaptive integrator, a path's kinematics): plain
# arrays in and out, the workspace made inside (making one costs well under a microsecond), then passed
# with the array that holds it to the function that does the work
@njit(cache=True)
def reduced_rhs(q_base, y, tau, P, min_abs_s, q_out):
    """``(θ̇, θ̈)`` of the reduced plant at ``y = (θ, θ̇)`` under efforts ``tau``, for an adaptive integrator;
    the passive coordinates by branch following from ``q_base`` (a configuration on the manifold), the
    configuration reached into ``q_out``. Returns ``(ẏ, status)``."""
    return _reduced_rhs(make_workspaces(1), q_base, y, tau, P, min_abs_s, q_out)


@njit(cache=True)
def _reduced_rhs(workspaces, q_base, y, tau, P, min_abs_s, q_out):
    n = N_ACTUATORS
    ws = workspaces[0]
    out = np.zeros(2 * n)
    # an adaptive integrator's trial steps may be long: branch following in sub-steps where needed
    status = follow_branch_in_steps(ws, q_base, y[:n], P, min_abs_s, np.inf)
    if status == OK:
        status = plant_stage(ws, y[:n], y[n:], tau, P, min_abs_s, BASE, False)
    for i in range(N_COORDINATES):
        q_out[i] = ws.q[BASE, i]
    if status == OK:
        for i in range(n):
            out[i] = y[n + i]
            out[n + i] = ws.theta_ddot[i]
    return out, status


@njit(cache=True)
def control_effort_from(q_base, kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, min_abs_s,
                        q_out, tau):
    """:func:`control_effort` with the controller's model at ``q_base`` before the measurement; its
    configuration at the measured ``theta`` into ``q_out``. Returns the status."""
    return _control_effort_from(make_workspaces(1), q_base, kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d,
                                theta_ddot_d, P, min_abs_s, q_out, tau)


@njit(cache=True)
def _control_effort_from(workspaces, q_base, kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P,
                         min_abs_s, q_out, tau):
    ws = workspaces[0]
    if kind == 1:  # PD: no model to move
        q_out[:] = q_base
        return control_effort(kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, min_abs_s,
                              ws, tau)
    # computed torque: the model follows the measurement, in sub-steps where needed
    status = follow_branch_in_steps(ws, q_base, theta, P, min_abs_s, np.inf)
    if status == OK:
        status = computed_torque(kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau)
    for i in range(N_COORDINATES):
        q_out[i] = ws.q[BASE, i]
    return status


@njit(cache=True)
def branch_following_batch(q_previous, thetas, P, min_abs_s, max_step, q_out, status):
    """:func:`follow_branch_in_steps` from each ``q_previous[k]`` (K, N) to ``thetas[k]`` (K, n), into ``q_out``
    (K, N) and ``status`` (K,)."""
    _branch_following_batch(make_workspaces(1), q_previous, thetas, P, min_abs_s, max_step, q_out, status)


@njit(cache=True)
def _branch_following_batch(workspaces, q_previous, thetas, P, min_abs_s, max_step, q_out, status):
    ws = workspaces[0]
    for k in range(thetas.shape[0]):
        status[k] = follow_branch_in_steps(ws, q_previous[k], thetas[k], P, min_abs_s, max_step)
        for i in range(N_COORDINATES):
            q_out[k, i] = ws.q[BASE, i]


@njit(cache=True)
def follow_path(q_start, thetas, P, min_abs_s, q_out):
    """Branch following from ``q_start`` through the actuator values ``thetas`` (K, n) in turn
    (:func:`follow_branch_in_steps`), into ``q_out`` (K, N); returns ``(status, k)``, ``k`` the first point
    not reached (else -1)."""
    return _follow_path(make_workspaces(1), q_start, thetas, P, min_abs_s, q_out)


@njit(cache=True)
def _follow_path(workspaces, q_start, thetas, P, min_abs_s, q_out):
    ws = workspaces[0]
    previous = q_start.copy()
    for k in range(thetas.shape[0]):
        status = follow_branch_in_steps(ws, previous, thetas[k], P, min_abs_s, np.inf)
        if status != OK:
            return status, k
        for i in range(N_COORDINATES):
            q_out[k, i] = previous[i] = ws.q[BASE, i]
    return OK, -1
