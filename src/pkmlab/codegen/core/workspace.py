"""The compiled core, its foundations: status codes, Newton's tolerances, the workspace record every function works in,
and the batch evaluators of the structure's kernels.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what a structure's generated module defines before the template's text
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import (  # noqa: F401
        ANGLES,
        ANGULAR,
        BLOCK_END,
        BODY_ROWS,
        DEPENDENT,
        DIM,
        DOF,
        ELIMINATED,
        GRAVITY_INDEX,
        INDEPENDENT,
        INERTIA_INDEX,
        JB_BODY,
        JB_COL,
        JB_ROW,
        LEADING,
        LINE_WIDTH,
        MASS_INDEX,
        MEASURE_LINES,
        N_ACTUATORS,
        N_BODIES,
        N_CONSTRAINTS,
        N_COORDINATES,
        N_INDEPENDENT,
        N_JB,
        N_POSE,
        POINT_COLUMNS,
        REDUCED_COLUMNS,
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


# ==== TEMPLATE
import numpy as np  # noqa: E402

# what every part of the compiled core uses (the parts after this one, too)
from pkmlab._compile_cache import (  # noqa: E402, F401
    INTERPRETED,
    NO_REFCOUNT,
    NO_REFCOUNT_INLINE,
    NO_REFCOUNT_PYTHON,
    NO_WRAPPERS,
    call_native,
    njit,
    prange,
)
from pkmlab.numerics.closed_chain import (  # noqa: E402, F401
    ldlt_solve,
    lu_factor,
    lu_solve_factored,
)

#: Status codes of the compiled functions (as :mod:`pkmlab.paper.rrr3`'s).
OK = 0
NOT_CONVERGED = 1  # Newton's method did not converge (no nearby configuration)
SINGULAR = 2  # |S| fell below the guard, S changed sign, or a matrix was singular
PLANT_FAILED = 3  # a plant stepped by native code (MuJoCo) turned non-finite or warned
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


BASE = 0
TRIAL = 1

#: The plant's drives (:mod:`pkmlab.simulation.realism`): one row per actuator of these columns, at the joint —
#: the reflected armature (kg m² or kg), viscous and Coulomb friction, the rate below which Coulomb friction is
#: smoothed (0: exact, ``fc sign(θ̇)``) or, for stick–slip, the rate below which the actuator may stick (Karnopp's
#: window), the largest effort, and 1 for stick–slip friction; no rows for ideal drives.
ARMATURE = 0
VISCOUS = 1
COULOMB = 2
COULOMB_RATE = 3
EFFORT_LIMIT = 4
STICK_SLIP = 5
DRIVE_COLUMNS = 6
NO_DRIVES = np.zeros((0, DRIVE_COLUMNS))
#: How the controller gets the actuators' rates (the loop's ``sensing``): the plant's own state (ideal sensors),
#: the plant's exact rates beside measured values, the measured values differenced sample to sample, or their
#: second-order backward difference ``(3 θ_k - 4 θ_k-1 + θ_k-2) / (2 Ts)`` (no half-sample lag).
IDEAL_SENSORS = -1
EXACT_RATES = 0
DIFFERENCED_RATES = 1
BACKWARD_RATES = 2

# Every leg closes on the platform by DIM equations (2 in the plane, 3 in space: its point rows, the first
# POINT_ROWS of η) whose derivatives with respect to the tracked point (x, y[, z]) are minus the identity
# (η = end of the leg's chain - attachment point); the rows after them (a universal joint's at a rigid
# platform) do not depend on it. Where the tracked point is a dependent coordinate, eliminating it with these unit
# pivots leaves a system of ELIMINATED = DIM equations fewer in the other dependent coordinates (the passive joints,
# the orientation and any parasitic motion), to be factored instead of the whole of Jηφ; where it is independent (a
# redundantly actuated machine's), ELIMINATED = 0 and the reduced system is Jηφ itself. POINT_COLUMNS are the tracked
# point's columns in Jηφ, REDUCED_COLUMNS the others (the generated module's).
REDUCED = N_CONSTRAINTS - ELIMINATED
#: Jηφ (in REDUCED_COLUMNS' order) is block diagonal, one block per leg (BLOCK_END): a redundantly actuated
#: machine's, whose legs close each on its independent pose. Factored block by block; elsewhere whole.
BLOCKED = REDUCED > 1 and BLOCK_END[0] < REDUCED
#: Where each reduced column's block starts.
BLOCK_START = tuple(max([end for end in BLOCK_END if end <= i], default=0) for i in range(REDUCED))
#: More actuators than independent coordinates: a redundantly actuated machine, whose efforts are distributed
#: (:func:`distribute`) and reach its pose through ``Wᵀ`` (:func:`generalised_force`).
REDUNDANT = N_ACTUATORS != N_INDEPENDENT


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
    ("j_q_theta", np.float64, (N_COORDINATES, N_INDEPENDENT)),  # Jqθ (eq. 31)
    ("q_dot", np.float64, (N_COORDINATES,)),
    ("bias_q", np.float64, (N_COORDINATES,)),  # J̇qθ θ̇ (eq. 32)
    ("gamma", np.float64, (N_CONSTRAINTS,)),  # J̇ηq q̇
    ("jb", np.float64, (N_JB,)),  # the non-zeros of the bodies' Jacobians
    ("bb", np.float64, (N_BODIES, BODY_ROWS)),  # bodies' J̇ q̇, then their accelerations at θ̈ = 0
    ("jt", np.float64, (N_BODIES, BODY_ROWS, N_INDEPENDENT)),  # the bodies' Jacobians times Jqθ
    ("inertia_jt", np.float64, (N_BODIES, 3, N_INDEPENDENT)),  # a spatial body's inertia tensor times its rows ω of jt
    ("m_theta", np.float64, (N_INDEPENDENT, N_INDEPENDENT)),  # Mθ
    ("c_theta", np.float64, (N_INDEPENDENT,)),  # cθ = Cθ θ̇
    ("g_theta", np.float64, (N_INDEPENDENT,)),  # gθ = ∂V/∂θ
    ("theta_ddot", np.float64, (N_INDEPENDENT,)),
    ("ldl", np.float64, (N_INDEPENDENT, N_INDEPENDENT)),  # factor of Mθ
    ("m_drives", np.float64, (N_INDEPENDENT, N_INDEPENDENT)),  # Mθ + Ia, kept while stuck actuators' rows are replaced
    ("free_rhs", np.float64, (N_INDEPENDENT,)),  # the efforts less friction of the actuators that move
    ("stuck", np.int64, (N_INDEPENDENT,)),  # 1 for an actuator held by its stick-slip friction
    ("lines", np.float64, (N_ACTUATORS, LINE_WIDTH)),  # the legs' lines of action
    ("lu_base", np.float64, (REDUCED, REDUCED)),  # the same factors at the base, kept for branch following from it
    ("piv_base", np.int64, (REDUCED,)),
    ("j_q_theta_base", np.float64, (N_COORDINATES, N_INDEPENDENT)),  # Jqθ at the base
    ("base_factored", np.int64, (1,)),  # 1 when the three above are the base's
    ("top", np.float64, (ELIMINATED, REDUCED)),  # rows 0 .. ELIMINATED - 1 of Jηφ in the reduced system's columns
    ("top_base", np.float64, (ELIMINATED, REDUCED)),  # the same at the base
    ("reduced", np.float64, (REDUCED, REDUCED)),  # the reduced system before factoring
    ("work", np.float64, (N_CONSTRAINTS,)),  # the reduced system's right-hand side, then the eliminated point's values
    ("rhs", np.float64, (N_CONSTRAINTS,)),
    ("start", np.float64, (N_INDEPENDENT,)),  # the independent coordinates follow_branch_in_steps starts from
    ("target", np.float64, (N_INDEPENDENT,)),  # the independent coordinates of a sub-step of follow_branch_in_steps
    ("step", np.float64, (N_INDEPENDENT,)),  # the independent coordinates' step of follow_branch's predictor
    ("force", np.float64, (N_INDEPENDENT,)),  # a generalised force on the independent coordinates, to distribute
    ("normal", np.float64, (N_INDEPENDENT, N_INDEPENDENT)),  # Wᵀ D⁻¹ W of the distribution, and its factor
    ("normal_ldl", np.float64, (N_INDEPENDENT, N_INDEPENDENT)),
    ("internal", np.float64, (N_ACTUATORS, N_ACTUATORS)),  # internal efforts: columns of the projector onto them
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
def independent_column(j):
    """``q``'s column of the j-th independent coordinate."""
    return j if LEADING else INDEPENDENT[j]


@njit(**NO_REFCOUNT_INLINE)
def dependent_column(i):
    """``q``'s column of the i-th dependent coordinate (the i-th column of ``Jηφ``)."""
    return N_INDEPENDENT + i if LEADING else DEPENDENT[i]


@njit(**NO_REFCOUNT_INLINE)
def generalised_force(ws, tau, i):
    """The generalised force the actuators' efforts ``tau`` exert on the i-th independent coordinate: ``τ_i``, or
    for a redundantly actuated machine ``(Wᵀ τ)_i`` with ``W = ∂θ/∂x``, the actuators' rows of ``ws.j_q_theta``
    (the actuators are ``q``'s first coordinates)."""
    if not REDUNDANT:
        return tau[i]
    acc = 0.0
    for a in range(N_ACTUATORS):
        acc += ws.j_q_theta[a, i] * tau[a]
    return acc


@njit(**NO_REFCOUNT_INLINE)
def actuator_component(ws, a, v):
    """``(W v)_a``: what a vector ``v`` of the independent coordinates (a redundantly actuated machine's pose's rates,
    accelerations…) is at actuator ``a``, ``W`` the actuators' rows of ``ws.j_q_theta`` (the transpose of
    :func:`generalised_force`): ``θ̇_a = (W ẋ)_a``."""
    acc = 0.0
    for j in range(N_INDEPENDENT):
        acc += ws.j_q_theta[a, j] * v[j]
    return acc


@njit(**NO_REFCOUNT_INLINE)
def wrapped(e, angle):
    """The difference ``e`` of two coordinates, for angles (``angle``) wrapped to ``(-π, π]``: the shorter way
    round."""
    return (e + np.pi) % (2.0 * np.pi) - np.pi if angle else e


@njit(**NO_REFCOUNT)
def actuator_error(theta, theta_d, i):
    """``θ_i - θ_d,i`` of the i-th independent coordinate, wrapped to ``(-π, π]`` for an angle (a revolute
    actuator, an orientation)."""
    return wrapped(theta[i] - theta_d[i], ANGLES[independent_column(i)])
