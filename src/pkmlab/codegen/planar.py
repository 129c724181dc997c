"""Symbolic derivation of a planar mechanism's kinematics, generated as compiled kernels.

From a :class:`~pkmlab.description.mechanism.Mechanism` this module derives, with SymPy, in
the coordinates

    q = (actuator values, passive joint coordinates leg by leg, pose)

(the actuated ones first, as the paper orders ``q = (θ, φ)``; the pose ``(x, y[, alpha])`` is
part of the passive set, so every leg closes on the platform by two equations):

* the loop-closure constraints ``η(q) = 0`` — for each leg, the end of its chain minus its
  platform attachment point, x then y (2 per leg);
* their Jacobian ``Jηq = ∂η/∂q`` and the bias ``J̇ηq q̇`` that the acceleration kinematics
  (paper eq. 32) needs;
* for every body (the legs' bodies, then the platform): the pose of its mass centre
  ``(x, y, angle)``, its Jacobian ``J_b = ∂(x, y, angle)/∂q`` (rows: linear velocity, angular
  velocity) and the bias ``J̇_b q̇`` — everything the constrained Lagrangian model (paper eqs.
  20–26) and its reduction to the actuator space (eq. 35) are built from, written once, for any
  mechanism;
* the legs' lines of action (for the singularity measure), every joint's position (for drawing)
  and the structural non-zeros of the body Jacobians.

The generated module then carries the compiled core of :mod:`pkmlab.codegen.core` (branch
following, actuator-space dynamics, control, the sampled-data loop), appended as text so that it
is compiled against this structure's kernels.

Only the *structure* of the mechanism (its legs' joints and its platform's kind) enters the
code; every number (base points, tips, mass centres, masses, inertias, attachment points,
gravity) is read from a packed parameter vector (:func:`pack`), so one generated module serves
every machine of the same structure. Common subexpressions are shared (``sympy.cse``) and the
code is straight-line, which Numba keeps in registers.

Run ``python -m pkmlab.codegen.planar`` to regenerate the modules of pkmlab's presets in
``pkmlab/kernels/``; ``--check`` exits non-zero when a committed file is not
current (the test suite checks it too).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..description.mechanism import Mechanism

GENERATED_DIR = Path(__file__).resolve().parents[1] / "kernels"


# ------------------------------------------------------------------ structure and parameters
def structure(mechanism: Mechanism) -> str:
    """The name of the mechanism's structure, which is all the generated code depends on:
    ``"RaRR_RaRR_RaRR_rigid"`` for the 3-RRR (``a`` marks the actuated joint)."""
    return "_".join(leg.notation.replace("*", "a") for leg in mechanism.legs) + "_" + mechanism.platform.kind


def coordinate_names(mechanism: Mechanism) -> tuple[str, ...]:
    """Names of ``q``: ``a1..an`` (actuators), ``q<leg>_<joint>`` (passive joints), then the pose."""
    names = [f"a{k + 1}" for k in range(len(mechanism.actuators))]
    for i, leg in enumerate(mechanism.legs):
        names += [f"q{i + 1}_{k + 1}" for k, j in enumerate(leg.joints[:-1]) if not j.actuated]
    return (*names, *mechanism.platform.pose_names)


def coordinate_angles(mechanism: Mechanism) -> tuple[bool, ...]:
    """For each coordinate of :func:`coordinate_names`, whether it is an angle (a revolute joint's, or alpha)."""
    angles = [kind == "R" for kind in mechanism.actuator_kinds]
    for leg in mechanism.legs:
        angles += [j.kind == "R" for j in leg.joints[:-1] if not j.actuated]
    return (*angles, *(name == "alpha" for name in mechanism.platform.pose_names))


def parameter_names(mechanism: Mechanism) -> tuple[str, ...]:
    """Names of the packed parameter vector, in order (:func:`pack`)."""
    names = []
    for i, leg in enumerate(mechanism.legs):
        names += [f"base{i + 1}_x", f"base{i + 1}_y"]
        if leg.joints[0].axis is not None:  # a rail: its unit direction (no trigonometry in the kernels)
            names += [f"rail{i + 1}_x", f"rail{i + 1}_y"]
        for k in range(len(leg.bodies)):
            pre = f"body{i + 1}_{k + 1}"
            names += [f"{pre}_tip_x", f"{pre}_tip_y", f"{pre}_com_x", f"{pre}_com_y", f"{pre}_mass", f"{pre}_inertia"]
    if mechanism.platform.kind == "rigid":
        for i in range(len(mechanism.legs)):
            names += [f"attach{i + 1}_x", f"attach{i + 1}_y"]
        names += ["platform_com_x", "platform_com_y"]
    names += ["platform_mass", "platform_inertia", "gravity_x", "gravity_y"]
    return tuple(names)


def pack(mechanism: Mechanism) -> np.ndarray:
    """The parameter vector of ``mechanism`` read by its generated kernels (:func:`parameter_names`)."""
    values = []
    for leg in mechanism.legs:
        values += [*leg.base]
        if leg.joints[0].axis is not None:
            values += [np.cos(leg.joints[0].axis), np.sin(leg.joints[0].axis)]
        for body in leg.bodies:
            values += [*body.tip, *body.com, body.mass, body.inertia]
    if mechanism.platform.kind == "rigid":
        for point in mechanism.platform.attachments:
            values += [*point]
        values += [*mechanism.platform.com]
    values += [mechanism.platform.mass, mechanism.platform.inertia, *mechanism.gravity]
    return np.array(values, dtype=float)


# ------------------------------------------------------------------ the derivation
def derive(mechanism: Mechanism) -> dict:
    """The symbolic kinematics of ``mechanism``'s structure.

    Returns ``{"q", "q_dot", "P": symbols; "eta": (m,), "bodies": [(x, y, angle), ...] (mass
    centres, legs' bodies then the platform)}`` as SymPy expressions of ``q`` and ``P``.
    """
    import sympy as sp

    q = sp.symbols(" ".join(coordinate_names(mechanism)), real=True)
    q_dot = sp.symbols(" ".join(f"{n}_dot" for n in coordinate_names(mechanism)), real=True)
    P = dict(zip(parameter_names(mechanism), sp.symbols(" ".join(parameter_names(mechanism)), real=True),
                 strict=True))
    n, n_pose = len(mechanism.actuators), len(mechanism.platform.pose_names)
    pose = q[len(q) - n_pose:]
    alpha = pose[2] if mechanism.platform.kind == "rigid" else sp.Integer(0)
    platform_rot = sp.Matrix([[sp.cos(alpha), -sp.sin(alpha)], [sp.sin(alpha), sp.cos(alpha)]])
    actuators, passive = iter(q[:n]), iter(q[n:len(q) - n_pose])
    eta, bodies, joints, slides = [], [], [], []
    for i, leg in enumerate(mechanism.legs):
        point = sp.Matrix([P[f"base{i + 1}_x"], P[f"base{i + 1}_y"]])
        direction, unit = sp.Integer(0), (sp.Integer(1), sp.Integer(0))  # the last body's angle, (cos, sin)
        joints.append([])
        slides.append({})  # the direction of each prismatic joint's slide
        for k, (joint, _body) in enumerate(zip(leg.joints, leg.bodies, strict=False)):
            joints[i].append(point)
            coordinate = next(actuators) if joint.actuated else next(passive)
            if joint.kind == "R":  # the following body's absolute angle
                direction, unit, origin = coordinate, (sp.cos(coordinate), sp.sin(coordinate)), point
            else:  # a slide along the rail (first joint) or along the preceding body, which keeps its direction
                if k == 0:  # the rail's unit vector is a parameter: no trigonometry of a constant in the kernels
                    unit = (P[f"rail{i + 1}_x"], P[f"rail{i + 1}_y"])
                    direction = sp.atan2(unit[1], unit[0])
                origin = point + coordinate * sp.Matrix(unit)
                slides[i][k] = unit
            rot = sp.Matrix([[unit[0], -unit[1]], [unit[1], unit[0]]])
            pre = f"body{i + 1}_{k + 1}"
            com = origin + rot * sp.Matrix([P[f"{pre}_com_x"], P[f"{pre}_com_y"]])
            bodies.append((com[0], com[1], direction))
            point = origin + rot * sp.Matrix([P[f"{pre}_tip_x"], P[f"{pre}_tip_y"]])
        attach = (sp.Matrix([P[f"attach{i + 1}_x"], P[f"attach{i + 1}_y"]]) if mechanism.platform.kind == "rigid"
                  else sp.zeros(2, 1))
        target = sp.Matrix(pose[:2]) + platform_rot * attach
        eta += [point[0] - target[0], point[1] - target[1]]
        joints[i].append(target)  # the last joint: on the platform
    if mechanism.platform.kind == "rigid":
        com = sp.Matrix(pose[:2]) + platform_rot * sp.Matrix([P["platform_com_x"], P["platform_com_y"]])
        bodies.append((com[0], com[1], alpha))
    else:
        bodies.append((pose[0], pose[1], sp.Integer(0)))  # a payload at the point: it does not turn
    return {"q": q, "q_dot": q_dot, "P": P, "eta": eta, "bodies": bodies, "joints": joints,
            "lines": _leg_lines(mechanism, P, pose, joints, slides)}


def _leg_lines(mechanism: Mechanism, P: dict, pose, joints, slides):
    """The lines along which the legs push the platform, and the platform's size.

    With its actuator held, a leg pushes the platform through its attachment point ``p_i`` along a line
    its passive joint decides. A passive revolute at ``c_i`` and the next revolute joint ``d_i`` (the
    platform's own, or an actuated one that holds the next body's angle) pin a two-force member: the line
    is parallel to ``d_i - c_i`` (``p_i - c_i`` for the elbow of an RRR or PRR leg and the base pivot of
    a telescopic RPR leg). A passive prismatic joint sliding along ``u_i`` carries no force along it: the
    line is across the slide, ``u_i`` turned by 90°.
    Returns, per leg, ``(p_i - p, direction)`` (``p`` the tracked point) as 4 expressions, and ``ℓ``, the
    mean distance between the attachment points (1 for a point platform): what
    :func:`pkmlab.codegen.core.branch_following.singularity_measure` needs.
    """
    import sympy as sp

    lines = []
    for leg, points, slide in zip(mechanism.legs, joints, slides, strict=True):
        # the passive joint before the platform (an extra actuator counted passive: the line of the leg's own)
        k = max(k for k, j in enumerate(leg.joints[:-1]) if not j.actuated or k in leg.extra_actuated)
        if leg.joints[k].kind == "R":
            after = next(j for j in range(k + 1, len(leg.joints)) if leg.joints[j].kind == "R")
            d = points[after] - points[k]
        else:
            d = sp.Matrix([-slide[k][1], slide[k][0]])
        lines += [points[-1][0] - pose[0], points[-1][1] - pose[1], d[0], d[1]]
    if mechanism.platform.kind == "point":
        return lines, sp.Integer(1)
    count = len(mechanism.legs)
    pairs = [(i, j) for i in range(count) for j in range(i)]
    size = sum(sp.sqrt((P[f"attach{i + 1}_x"] - P[f"attach{j + 1}_x"]) ** 2
                       + (P[f"attach{i + 1}_y"] - P[f"attach{j + 1}_y"]) ** 2) for i, j in pairs) / len(pairs)
    return lines, size


def jacobian(exprs, variables):
    """``∂exprs/∂variables``, a SymPy matrix: SymPy's ``Matrix.jacobian``, entry for entry the same expressions,
    with each row's free symbols found once. SymPy's derivative finds them again for every entry, which costs as much as
    the derivative where the row does not hold the variable: a closed chain's rows hold one leg's coordinates each, so
    most entries are such zeros (a fifth of a four-legged spatial machine's derivation).

    Each row is differentiated by SymEngine, about five times faster than SymPy (a new structure's derivation is on
    its first run's path), and converted back: the same expressions as SymPy's own derivative, entry for entry
    (``tests/test_derivation.py``; the shipped modules' derivation check too), once the symbols SymEngine returns
    without SymPy's assumptions (``real=True``, which the trig table's ``sin(q)`` keys carry) are put back by name."""
    import symengine
    import sympy as sp

    wrt = [symengine.sympify(v) for v in variables]
    rows = []
    for e in exprs:
        held = e.free_symbols
        if not any(v in held for v in variables):
            rows.append([sp.S.Zero] * len(variables))
            continue
        row, own = symengine.sympify(e), {sp.Symbol(s.name): s for s in held}
        rows.append([sp.sympify(row.diff(w)).xreplace(own) if v in held else sp.S.Zero
                     for v, w in zip(variables, wrt, strict=True)])
    return sp.Matrix(len(rows), len(variables), [e for row in rows for e in row])


def jacobian_and_bias(exprs, q, q_dot):
    """``J = ∂exprs/∂q`` and ``J̇ q̇ = Σ_k (∂(J q̇)/∂q_k) q̇_k`` (the terms of the acceleration that do
    not multiply ``q̈``)."""
    import sympy as sp

    jac = jacobian(exprs, q)
    velocity = jac * sp.Matrix(q_dot)
    bias = jacobian(velocity, q) * sp.Matrix(q_dot)
    return jac, bias


# ------------------------------------------------------------------ code generation
@dataclass(frozen=True)
class Block:
    """Outputs of a kernel written by one stretch of straight-line code: ``out[index] = output`` (or ``return
    output`` for the index ``"return"``), its common subexpressions shared (``sympy.cse``). With ``loop`` (a
    ``for`` line, e.g. over the legs of one type), the code is the body of that loop: the outputs are one leg's, of
    the names ``unpack`` binds from the loop variable (each line kept only where the code uses its name), and
    ``trig`` maps the cosines and sines of its angles to the names of the trig table that ``unpack`` binds."""

    outputs: list
    indices: list[str]
    loop: str | None = None
    unpack: tuple[str, ...] = ()
    trig: dict = field(default_factory=dict)


def _emit(lines, name, args, doc, blocks, fill=False):
    """A compiled kernel writing the outputs of ``blocks``; ``fill``: every entry of ``out`` it does not write is
    0 (a sparse Jacobian), as is every output that is 0."""
    import sympy as sp

    lines += ["", "", "@njit(cache=True)", f"def {name}({args}):", f'    """{doc}"""']
    fill = fill or any(e == 0 for block in blocks for e in block.outputs)
    for number, block in enumerate(blocks):
        nonzero = [(ix, e) for ix, e in zip(block.indices, block.outputs, strict=True) if e != 0]
        symbols = sp.numbered_symbols("w" if number == 0 else f"w{number}_")
        replacements, reduced = sp.cse([e for _ix, e in nonzero], symbols=symbols, order="canonical")
        body = [f"{sym} = {sp.pycode(expr)}" for sym, expr in replacements]
        if fill and number == 0:
            if block.loop:
                lines.append("    out[:] = 0.0")
            else:
                body.append("out[:] = 0.0")
        body += [f"return {sp.pycode(expr)}" if ix == "return" else f"out[{ix}] = {sp.pycode(expr)}"
                 for (ix, _e), expr in zip(nonzero, reduced, strict=True)]
        if block.loop is None:
            lines += [f"    {line}" for line in body]
        elif nonzero:
            kept: list[str] = []
            for line in reversed(block.unpack):  # an index bound for the unpacking lines is kept with them
                if _used(line, "\n".join(kept + body)):
                    kept.insert(0, line)
            lines += [f"    {block.loop}", *(f"        {line}" for line in kept + body)]


def generate_source(mechanism: Mechanism) -> str:
    """The text of the generated module of ``mechanism``'s structure."""

    d = derive(mechanism)
    q, q_dot = d["q"], d["q_dot"]
    nq, m, nb = len(q), len(d["eta"]), len(d["bodies"])
    j_eta, b_eta = jacobian_and_bias(d["eta"], q, q_dot)
    # the compiled core eliminates x and y with the unit pivots every leg's two equations have
    n_pose = len(mechanism.platform.pose_names)
    x_col = nq - n_pose
    for i in range(len(mechanism.legs)):
        assert (j_eta[2 * i, x_col], j_eta[2 * i, x_col + 1]) == (-1, 0), "x-row of a leg: d/dx = -1, d/dy = 0"
        assert (j_eta[2 * i + 1, x_col], j_eta[2 * i + 1, x_col + 1]) == (0, -1), "y-row: d/dx = 0, d/dy = -1"
    body_exprs = [e for body in d["bodies"] for e in body]
    j_body, b_body = jacobian_and_bias(body_exprs, q, q_dot)
    # the body Jacobians' structural non-zeros: a leg's bodies move with that leg's coordinates only
    nonzero = [(b, r, c) for b in range(nb) for r in range(3) for c in range(nq) if j_body[3 * b + r, c] != 0]
    header = module_header(
        "planar", mechanism, structure(mechanism), coordinate_names(mechanism), coordinate_angles(mechanism),
        parameter_names(mechanism), (nq, m, nb),
        "# in the plane: 2 linear and 1 angular rows per body Jacobian, lines of action (point, direction) of 4",
        (2, 1, 3, 4), "# where each body's mass and inertia (legs' bodies, then the platform) and the gravity are in P",
        [_indices(mechanism, what) for what in ("mass", "inertia", "gravity")], nonzero,
        layout=(n_pose, [x_col - len(mechanism.actuators) + c for c in range(2)], True),
        pattern={(r, c) for r in range(m) for c in range(nq) if j_eta[r, c] != 0})
    width = max(len(leg.joints) for leg in mechanism.legs)
    points, where = [], []
    for i, leg_points in enumerate(d["joints"]):
        padded = leg_points + [leg_points[-1]] * (width - len(leg_points))  # short legs repeat their end
        points += [c for point in padded for c in point]
        where += [f"{i}, {k}, {c}" for k in range(width) for c in range(2)]
    lines_, size = d["lines"]
    kernels = [
        ("constraints", "q, sc, P, out", "Write the loop-closure residual eta(q) (N_CONSTRAINTS,) into out.",
         d["eta"], [str(k) for k in range(m)]),
        ("constraint_jacobian", "q, sc, P, out",
         "Write J_eta_q = d eta / dq (N_CONSTRAINTS, N_COORDINATES) into out.",
         list(j_eta), [f"{r}, {c}" for r in range(m) for c in range(nq)]),
        ("constraint_bias", "q, sc, q_dot, P, out", "Write dJ_eta_q/dt q_dot (N_CONSTRAINTS,) into out.",
         list(b_eta), [str(k) for k in range(m)]),
        ("body_poses", "q, sc, P, out", "Write each body's mass-centre pose (x, y, angle) (N_BODIES, 3) into out.",
         body_exprs, [f"{b}, {k}" for b in range(nb) for k in range(3)]),
        ("body_jacobians", "q, sc, P, out",
         "Write each body's d(x, y, angle)/dq (N_BODIES, 3, N_COORDINATES) into out.",
         list(j_body), [f"{b}, {k}, {c}" for b in range(nb) for k in range(3) for c in range(nq)]),
        ("body_jacobian_values", "q, sc, P, out", "Write the non-zeros of the bodies' Jacobians (N_JB,) into out "
         "(positions: JB_BODY, JB_ROW, JB_COL).", [j_body[3 * b + r, c] for b, r, c in nonzero],
         [str(z) for z in range(len(nonzero))]),
        ("body_bias", "q, sc, q_dot, P, out", "Write each body's dJ_b/dt q_dot (N_BODIES, 3) into out.",
         list(b_body), [f"{b}, {k}" for b in range(nb) for k in range(3)]),
        ("joint_points", "q, sc, P, out", "Write every joint's position (N_LEGS, JOINTS_PER_LEG, 2) into out, "
         "base to platform.", points, where),
        ("leg_lines", "q, sc, P, out", "Write each leg's line of action (N_LEGS, 4): its attachment point "
         "minus the tracked point, and its direction (unnormalised).", lines_,
         [f"{i}, {k}" for i in range(len(mechanism.legs)) for k in range(4)]),
        ("platform_size", "P", "The mean distance between the platform's attachment points (1 for a point).",
         [size], ["return"]),
    ]
    kernels = [(name, args, doc, [Block(outputs, indices)]) for name, args, doc, outputs, indices in kernels]
    return write_module(header, q, q_dot, coordinate_names(mechanism), coordinate_angles(mechanism),
                        parameter_names(mechanism), independent_columns(mechanism, coordinate_names(mechanism)),
                        kernels)


def _permutation_sign(order) -> int:
    """+1 or -1: the sign of the permutation ``order`` of ``range(len(order))``."""
    sign, seen = 1, set()
    for start in range(len(order)):
        length, k = 0, start
        while k not in seen:
            seen.add(k)
            k = order[k]
            length += 1
        if length and length % 2 == 0:
            sign = -sign
    return sign


def diagonal_blocks(pattern, rows: int, dependent) -> tuple[tuple[int, ...], tuple[int, ...]] | None:
    """The columns of ``Jηφ`` (indices into ``dependent``, the dependent coordinates' columns of ``q``) in an order
    that makes it block diagonal, and the end of each one's block (exclusive), where it has two blocks or more whose
    rows are consecutive: a redundantly actuated machine's, whose legs close each on the pose (independent) by
    equations in that leg's coordinates only. ``pattern`` holds the structural non-zeros ``(row, column of q)`` of
    ``Jηq``; None for one block (or blocks not square or not on consecutive rows: factored whole)."""
    owner = list(range(rows))  # union-find over the rows, joined by the dependent columns they share

    def find(r):
        while owner[r] != r:
            owner[r] = owner[owner[r]]
            r = owner[r]
        return r

    first_row = {}
    for r, c in sorted(pattern):
        if c in dependent:
            if c in first_row:
                owner[find(r)] = find(first_row[c])
            else:
                first_row[c] = r
    blocks = {}
    for r in range(rows):
        blocks.setdefault(find(r), []).append(r)
    if len(blocks) < 2:
        return None
    order, ends = [], []
    for block_rows in sorted(blocks.values()):
        columns = [i for i, c in enumerate(dependent) if c in first_row and find(first_row[c]) == find(block_rows[0])]
        if block_rows != list(range(block_rows[0], block_rows[-1] + 1)) or len(columns) != len(block_rows):
            return None
        order += columns
        ends += [len(order)] * len(columns)
    return (tuple(order), tuple(ends)) if sorted(order) == list(range(len(dependent))) else None


def module_header(kind: str, mechanism, structure_name: str, names, angles, parameters, sizes, dims_comment: str,
                  dims, weights_comment: str, indices, nonzero, layout, point_rows=None, pattern=()) -> list[str]:
    """The head of a generated module of ``kind`` ("planar" or "spatial"): its docstring, imports and the
    constants the compiled core reads — coordinates, sizes ``(N_COORDINATES, N_CONSTRAINTS, N_BODIES)``,
    ``dims = (DIM, ANGULAR, BODY_ROWS, LINE_WIDTH)``, the positions in ``P`` of the masses, inertias and
    gravity (``indices``), the bodies' Jacobians' structural non-zeros ``(body, row, column)``, and
    ``layout = (N_POSE, point, lines)``: how many of ``q``'s last coordinates are the platform's pose, the
    columns of ``Jηφ`` of the tracked point (x, y[, z]), whether the singularity measure is the legs' lines';
    ``point_rows``, how many of ``η``'s rows are the legs' points' (DIM per leg, first; default all of them);
    ``pattern``, the structural non-zeros ``(row, column)`` of ``Jηq``.

    The compiled core's independent coordinates (:func:`independent_columns`) are the actuators, first in ``q``; a
    redundantly actuated machine's are its controlled pose, so that the tracked point is not eliminated, the
    singularity measure is ``Jηφ``'s scaled determinant, ``LINE_WIDTH`` is widened to hold ``Jηq``, and ``Jηφ``,
    one block per leg (:func:`diagonal_blocks`), is factored block by block."""
    import sympy as sp

    mass, inertia, gravity = indices
    n_pose, point, lines = layout
    independent = independent_columns(mechanism, names)
    leading = independent == tuple(range(len(independent)))
    dependent = tuple(c for c in range(sizes[0]) if c not in independent)
    if not leading:  # the tracked point is independent: nothing to eliminate
        point, lines = (), False
        dims = (*dims[:3], max(dims[3], -(-sizes[1] * sizes[0] // len(mechanism.actuators))))
    reduced = tuple(c for c in range(len(dependent)) if c not in point)
    ends = (len(reduced),) * len(reduced)
    blocks = None if leading else diagonal_blocks(pattern, sizes[1], dependent)
    if blocks is not None:
        reduced, ends = blocks
    return [
        f'"""GENERATED by ``python -m pkmlab.codegen.{kind}`` -- do not edit.',
        "",
        f"Kinematics of the {kind} structure {structure_name} (legs {mechanism.notation}, "
        f"{mechanism.platform.kind} platform);",
        f"see ``pkmlab.codegen.{kind}`` for the coordinates q, the parameters P and the meaning of each output.",
        f"Derived with SymPy {sp.__version__}.",
        '"""',
        "",
        "from pkmlab._compile_cache import njit",
        "",
        f"COORDINATES = {tuple(names)!r}",
        f"ANGLES = {tuple(angles)!r}  # which coordinates are angles (wrapped modulo 2 pi)",
        f"PARAMETERS = {tuple(parameters)!r}",
        f"N_COORDINATES, N_CONSTRAINTS, N_BODIES = {sizes[0]}, {sizes[1]}, {sizes[2]}",
        f"N_ACTUATORS, DOF, N_LEGS = {len(mechanism.actuators)}, {mechanism.dof}, {len(mechanism.legs)}",
        "# the compiled core's independent coordinates (q's columns): the actuators, or a redundantly actuated "
        "machine's controlled pose; the dependent ones (the columns of J_eta_phi, in order); whether the independent "
        "ones are q's first",
        f"N_INDEPENDENT = {len(independent)}",
        f"INDEPENDENT = {independent!r}",
        f"DEPENDENT = {dependent!r}",
        f"LEADING = {leading!r}",
        "# the rows of eta that close each leg's end point on the platform (DIM per leg, leg by leg; the others "
        "do not move with the tracked point)",
        f"POINT_ROWS = {sizes[1] if point_rows is None else point_rows}",
        "# the platform's pose: q's last N_POSE coordinates (its parasitic ones, then the DOF it is controlled in)",
        f"N_POSE = {n_pose}",
        "# the columns of J_eta_phi of the tracked point, and the others (the reduced system's, in order)",
        f"POINT_COLUMNS = {tuple(point)!r}",
        f"REDUCED_COLUMNS = {reduced!r}",
        "# the end (exclusive) of the diagonal block of J_eta_phi each reduced column is in (one block: all of them), "
        "and the sign of the reduced columns' permutation",
        f"BLOCK_END = {ends!r}",
        f"REDUCED_SIGN = {1 if blocks is None else _permutation_sign(reduced)}",
        "# whether S is the determinant of the legs' lines of action (else the scaled determinant of J_eta_phi)",
        f"MEASURE_LINES = {bool(lines)!r}",
        dims_comment,
        f"DIM, ANGULAR, BODY_ROWS, LINE_WIDTH = {', '.join(str(v) for v in dims)}",
        "# how many point rows of eta eliminate the tracked point from J_eta_phi (DIM, or 0 where it is independent)",
        f"ELIMINATED = {len(point)}",
        weights_comment,
        f"MASS_INDEX = {mass!r}",
        f"INERTIA_INDEX = {inertia!r}",
        f"GRAVITY_INDEX = {gravity!r}",
        f"JOINTS_PER_LEG = {max(len(leg.joints) for leg in mechanism.legs)}",
        "# the non-zeros of the bodies' Jacobians, in the order of body_jacobian_values: body, row, coordinate",
        f"JB_BODY = {tuple(b for b, _r, _c in nonzero)!r}",
        f"JB_ROW = {tuple(r for _b, r, _c in nonzero)!r}",
        f"JB_COL = {tuple(c for _b, _r, c in nonzero)!r}",
        f"N_JB = {len(nonzero)}",
    ]


def independent_columns(mechanism, names) -> tuple[int, ...]:
    """The columns of ``q`` (coordinates ``names``) that the compiled core takes as independent: the actuators
    (``q``'s first ``n_a``), or for a redundantly actuated machine the controlled pose, which its actuators
    over-determine."""
    if mechanism.actuation_redundancy == 0:
        return tuple(range(len(mechanism.actuators)))
    return tuple(names.index(name) for name in mechanism.pose_names)


def write_module(header: list[str], q, q_dot, names, angle_flags, parameters, independent, kernels) -> str:
    """The text of a generated module: ``header`` (docstring, imports, constants), the trig-table kernels
    ``trig`` and ``trig_passive`` (the angles of the dependent coordinates: not in ``independent``), one compiled
    kernel per ``(name, args, doc, blocks[, fill])`` of ``kernels`` (:class:`Block`, :func:`_emit`; a kernel reads
    ``q_dot`` when its arguments name it), then the compiled core of :mod:`pkmlab.codegen.core`."""
    import sympy as sp

    from .core import template

    lines = list(header)
    unpack = [f"{name} = q[{k}]" for k, name in enumerate(names)]
    unpack_q_dot = [f"{sym} = q_dot[{k}]" for k, sym in enumerate(q_dot)]
    unpack_p = [f"{name} = P[{k}]" for k, name in enumerate(parameters)]
    # the kernels read every angle's cosine and sine from the trig table sc = (cos q, sin q) (N, 2), computed
    # once per configuration (trig) and shared by all of them instead of recomputed in each
    angles = [k for k, is_angle in enumerate(angle_flags) if is_angle]
    trig = {}
    unpack_sc = []
    for k in angles:
        c, s = sp.symbols(f"c_{names[k]} s_{names[k]}", real=True)
        trig[sp.cos(q[k])], trig[sp.sin(q[k])] = c, s
        unpack_sc += [f"c_{names[k]} = sc[{k}, 0]", f"s_{names[k]} = sc[{k}, 1]"]
    lines += ["", "", "@njit(cache=True)", "def trig(q, sc):",
              '    """Write the trig table sc (N_COORDINATES, 2) of q: (cos, sin) of every angle."""']
    lines += [f"    sc[{k}, 0], sc[{k}, 1] = math.cos(q[{k}]), math.sin(q[{k}])" for k in angles]
    lines += ["", "", "@njit(cache=True)", "def trig_passive(q, sc):",
              '    """Write the dependent angles\' rows of the trig table sc (the independent ones are kept)."""']
    lines += [f"    sc[{k}, 0], sc[{k}, 1] = math.cos(q[{k}]), math.sin(q[{k}])" for k in angles
              if k not in independent] or ["    pass"]
    for name, args, doc, blocks, *fill in kernels:
        start = len(lines)
        blocks = [replace(block, outputs=[sp.sympify(e).xreplace({**trig, **block.trig}) for e in block.outputs])
                  for block in blocks]
        assert not any(e.has(sp.sin, sp.cos) for block in blocks for e in block.outputs), \
            f"{name}: trigonometry left after the trig table"
        _emit(lines, name, args, doc, blocks, *fill)
        body_start = start + 5
        prelude = [f"    {line}" for line in unpack + unpack_sc + (unpack_q_dot if "q_dot" in args.split(", ") else [])
                   + unpack_p]
        used = "\n".join(lines[body_start:])
        prelude = [p for p in prelude if _used(p, used)]
        lines[body_start:body_start] = prelude
    if any("math." in line for line in lines):
        lines.insert(lines.index("from pkmlab._compile_cache import njit"), "import math\n")
    text = "\n".join(lines) + "\n" + template()
    return text.replace("\n\n\n\n", "\n\n\n")


def _indices(mechanism: Mechanism, what: str) -> tuple[int, ...]:
    """Positions in ``P`` of every body's mass or inertia, or of the gravity vector."""
    names = parameter_names(mechanism)
    if what == "gravity":
        return names.index("gravity_x"), names.index("gravity_y")
    bodies = [f"body{i + 1}_{k + 1}" for i, leg in enumerate(mechanism.legs) for k in range(len(leg.bodies))]
    return tuple(names.index(f"{b}_{what}") for b in [*bodies, "platform"])


def _used(assignment: str, code: str) -> bool:
    import re

    name = assignment.strip().split(" = ")[0]
    return re.search(rf"\b{re.escape(name)}\b", code) is not None


def generated_path(mechanism: Mechanism) -> Path:
    return GENERATED_DIR / f"planar_{structure(mechanism)}.py"


def regenerate(argv, presets, derivation, name: str) -> int:
    """The command line of the derivation module ``name`` (``derivation``: its ``generated_path`` and
    ``generate_source``): write the generated module of every one of ``presets``, or with ``--check`` exit
    non-zero when a committed one is not current."""
    parser = argparse.ArgumentParser(description=derivation.__doc__.splitlines()[0], prog=f"python -m {name}")
    parser.add_argument("--check", action="store_true", help="fail if a file is not current")
    args = parser.parse_args(argv)
    from .provenance import record

    stale, written = 0, {}
    for make in presets.values():
        mechanism = make()
        path, source = derivation.generated_path(mechanism), derivation.generate_source(mechanism)
        if args.check:
            if not path.exists() or path.read_text() != source:
                print(f"{path} is not current: run python -m {name}")
                stale += 1
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(source)
        written[path.name] = source
        print(f"wrote {path}")
    if written:
        record(written)
    return 1 if stale else 0


def main(argv: list[str] | None = None) -> int:
    from ..description.presets import PLANAR_PRESETS

    return regenerate(argv, PLANAR_PRESETS, sys.modules[__name__], "pkmlab.codegen.planar")


if __name__ == "__main__":
    sys.exit(main())
