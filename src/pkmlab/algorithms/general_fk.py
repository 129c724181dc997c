"""Forward kinematics of every assembly mode of any spatial machine, by one general method: a parameter
homotopy on the machine's own loop-closure polynomials, from a generic instance solved once by monodromy.

**The polynomial system.** At given actuator values, the unknowns are the platform's whole pose and the
passive joints that the legs' ends do not eliminate. Each leg ends in a spherical joint at its attachment
point ``p_i = x + R a_i``; its last passive joint is eliminated in closed form:

* a universal joint (the R*US, UP*S and P*US legs): its body, and every actuated joint after it, keep the
  spherical joint at a fixed distance from its centre ``c``: ``|p_i − c|² = |w|²`` (a sphere);
* a revolute joint (P*RS, RP*S, R*RRS): the spherical joint turns on a circle about the hinge:
  ``(p_i − c)·n = w·a`` and ``|p_i − c|² = |w|²``;
* a prismatic joint: not eliminated (its slide is an unknown, the leg's three equations kept).

A leg that ends in a universal joint under a rigid platform adds its orientation row ``(R_leg a₁)·(R a₂) = 0``
(:mod:`pkmlab.description.mobility`; the rows an overconstrained machine sets aside are not in the system: its
solutions where they do not vanish, the assembly modes of the machine its kept rows describe but not of this
one, are dropped after polishing). Where the leg's last passive joint is a universal one eliminated as a sphere,
the row is polynomial when the joint's second axis is the platform joint's first and stays across the leg (each
leg's inner axes parallel, as in every 3-UPU): ``R_leg a₁`` is then along ``(R u₁) × (p_i − c)``. In any other leg
with such a row no joint is eliminated (a universal joint's two angles follow from ``p_i − c`` only up to a square
root, which is no polynomial): every passive angle is an unknown, the leg's three point equations and its row kept.
A leg ending in a revolute joint whose rows the model keeps (a 3-CRR's) is written the same way, with its kept rows
``(R_leg a)·(R b_k) = 0`` (``b_k`` across ``a``).

Every other passive angle ``φ`` is the pair ``(cos φ, sin φ)`` with ``c² + s² = 1``; the orientation is the
Cayley map ``R = R₀ ((1 − |g|²) I + 2 g gᵀ + 2 [g]×) / (1 + |g|²)`` of three unknowns ``g`` about a fixed
random rotation ``R₀`` (no double cover, unlike Euler angles or quaternions; the rotations it misses — a half
turn from ``R₀`` — are a set of measure zero, at no real solution with probability one); every equation is
multiplied by the powers of ``1 + |g|²`` that make it polynomial. Where the orientation rows alone fix the
orientation at every actuator value (three equations in ``g`` that no actuator enters: a 3-CRR's), ``R₀`` is
chosen far from the half turns of those rotations instead (:func:`_centred_chart`): one near a half turn from
``R₀`` would have a large ``g``, and monodromy's loops would hardly move it. The actuators enter as parameters (an
angle as its cosine and sine).

**The method.** The family ``F(z; θ) − b = 0`` (``b`` an offset, the trick that makes a start solution
free: a random complex ``z₀`` solves it at ``b₀ = F(z₀; θ₀)``) is solved at the generic complex parameters
``(θ₀, b₀)`` by monodromy (:func:`pkmlab.numerics.homotopy.monodromy_solve`), once per machine; every solve
is then a parameter homotopy from those solutions to ``(θ, 0)`` — as many paths as the machine has complex
assembly modes (40 for the general Stewart–Gough platform, 2 for the Delta), not a Bézout number. Each real
endpoint becomes a configuration (the eliminated joints' angles in closed form) polished by Newton's method
on the generated kernels' ``η = 0``; duplicates are merged.

**Completeness.** Every isolated solution at the target is the end of a path (the coefficient-parameter
theorem), provided the generic instance's solutions are all known. Monodromy's stopping rule (no new
solution in several loops in a row) is no proof, and can stop short: the Stewart preset's instance, from seven
seeds, had 22 to 29 solutions, 28 once merged. So a second instance, from another seed, is carried to the first's
parameters and merged with it (:func:`solve_generic_instance`): a solution one run missed, the other finds.
A solve is complete when its paths all ended at distinct regular solutions, or — where some went to
infinity, stopped short or jumped — when detours through other generic parameters confirm it
(:func:`general_assembly_modes`); otherwise the paths that failed or ended at singular solutions are reported
(:class:`GeneralAssembly`).

**Speed.** The family and its derivatives are a straight-line program (:mod:`pkmlab.numerics.straight_line`),
built once per machine from the SymPy system above (a second or two) and run by one compiled tracker
(:mod:`pkmlab.numerics.tracker`) for every machine: a solve of 16–40 paths takes 15–30 ms.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..description.general_legs import joint_unknowns, symbolic_chain
from ..description.mobility import across, kept_leg_rows
from ..errors import AssemblyError, InvalidParameterError
from ..numerics import homotopy
from .stewart_fk import rotation_of_quaternion

#: Seed of the generic instance and of R₀ (the same machine gets the same start solutions in every process).
SEED = 20261202


@dataclass(frozen=True)
class GeneralAssembly:
    """What a general forward-kinematics solve found: the real configurations (a list of ``q``, not yet
    polished), the number of paths tracked (the machine's complex assembly modes, from the generic instance),
    those that failed and those that ended at a singular solution near the reals (which may be a real assembly
    mode at a singularity), and the monodromy loops that found the generic instance's solutions."""

    configurations: list
    paths: int
    failed: int
    singular: int
    generic_loops: int

    @property
    def doubt(self) -> str:
        """Empty when every path ended at a regular solution or went to infinity; else what is unsure."""
        parts = []
        if self.failed:
            parts.append(f"{self.failed} of {self.paths} paths did not reach the target")
        if self.singular:
            parts.append(f"{self.singular} ended at singular solutions (a singularity at these actuator values)")
        return "; ".join(parts)


# ------------------------------------------------------------------ the symbolic system
def _leg_plan(leg):
    """Which passive joint of ``leg`` is eliminated (index, or None) and the unknown joints before it."""
    joints = leg.joints[:-1]
    passive = [k for k, j in enumerate(joints) if not j.actuated]
    last = passive[-1] if passive else None
    if last is not None and joints[last].kind == "P":
        return None, passive
    return last, [k for k in passive if k != last]


def build_system(description, R0: np.ndarray | None = None):
    """The polynomial system of ``description`` (module docstring): ``(equations, unknowns, parameters,
    layout)`` as SymPy objects; ``layout`` says how to read a solution. The orientation's chart is centred on
    ``R0`` (a random rotation by default)."""
    import sympy as sp

    m = description
    rng = np.random.default_rng(SEED)
    rigid = m.platform.kind == "rigid"
    X = sp.Matrix(sp.symbols("X Y Z"))
    unknowns = list(X)
    params = []
    equations = []
    if rigid:
        g = sp.Matrix(sp.symbols("g1 g2 g3"))
        unknowns += list(g)
        R0 = sp.Matrix(rotation_of_quaternion(rng.standard_normal(4)) if R0 is None else R0)
        D = 1 + (g.T * g)[0]
        skew = sp.Matrix([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
        R_num = R0 * ((1 - (g.T * g)[0]) * sp.eye(3) + 2 * g * g.T + 2 * skew)
    else:
        R0 = sp.eye(3)
        D, R_num = sp.Integer(1), sp.eye(3)
    legs_layout = []
    kept = kept_leg_rows(m)
    for i, leg in enumerate(m.legs):
        last, free = _leg_plan(leg)
        actuated = leg.joints[leg.actuated]
        if actuated.kind == "R":
            ca, sa = sp.symbols(f"ca{i + 1} sa{i + 1}")
            params += [ca, sa]
            theta = (ca, sa)
        else:
            ta = sp.Symbol(f"ta{i + 1}")
            params.append(ta)
            theta = (ta,)
        values = {leg.actuated: (theta,) if actuated.kind == "R" else theta}  # joint index -> (c, s) pairs or a slide
        n_joints = len(leg.joints) - 1
        held = bool(kept[i])  # orientation rows the model keeps (module docstring)
        revolute = leg.joints[-1].kind == "R"
        if held and revolute:  # its axis, in the leg's last body, across the kept directions in the platform
            a1 = sp.Matrix(leg.joints[-1].axes[0])
            across_ = [sp.Matrix(across(leg.joints[-1].axes[0])[k]) for k in kept[i]]
            last, free = None, [k for k, j in enumerate(leg.joints[:-1]) if not j.actuated]
        elif held:
            a1, a2 = (sp.Matrix(a) for a in leg.joints[-1].axes)
        if last is not None:
            # w: from the eliminated joint to the spherical joint, in the frame after the eliminated joint's turns
            # (the joints after it are actuated: known)
            w, after = symbolic_chain(leg, values, range(last + 1, n_joints), leg.bodies[last].tip)
            if held and not _row_survives_elimination(leg.joints[last], after * a1, w):
                last, free = None, [k for k, j in enumerate(leg.joints[:-1]) if not j.actuated]
        unknown_joints = []
        for k in free:
            values[k], more, circles = joint_unknowns(leg.joints[k], f"{i + 1}_{k + 1}")
            unknowns += more
            equations += circles
            unknown_joints.append(k)

        p_num = X * D + R_num * sp.Matrix(m.platform.attachments[i])  # D·(x + R a_i)
        if last is None:
            end, rot = symbolic_chain(leg, values, range(n_joints), leg.base)
            equations += list(p_num - end * D)
            if held and revolute:
                equations += [((rot * a1).T * (R_num * b))[0] for b in across_]
            elif held:
                equations.append(((rot * a1).T * (R_num * a2))[0])
            legs_layout.append(("point", last, unknown_joints))
            continue
        centre, rot = symbolic_chain(leg, values, range(last), leg.base)
        joint = leg.joints[last]
        d = p_num - centre * D
        if joint.kind == "U":
            equations.append((d.T * d)[0] - (w.T * w)[0] * D * D)
            if held:
                equations.append(_row_through_sphere(joint, after * a1, w, rot, d, R_num * a2, D))
            legs_layout.append(("sphere", last, unknown_joints))
        else:
            axis = sp.Matrix(joint.axes[0])
            normal = rot * axis
            equations.append((d.T * normal)[0] - (w.T * axis)[0] * D)
            equations.append((d.T * d)[0] - (w.T * w)[0] * D * D)
            legs_layout.append(("circle", last, unknown_joints))
    if len(equations) != len(unknowns):
        raise InvalidParameterError(f"{m.name}: its forward-kinematics system has {len(equations)} equations in "
                                    f"{len(unknowns)} unknowns (a leg pkmlab cannot reduce)")
    return equations, unknowns, params, {"legs": legs_layout, "R0": np.array(R0, dtype=float), "rigid": rigid}


#: Coefficients below this vanish in :func:`_vanishes`: axes written to six digits are perpendicular (the polynomial
#: system is then that close to the machine's, whose own rows polish every solution to round-off).
PARALLEL_TOL = 1e-6


def _vanishes(expression) -> bool:
    """Whether a polynomial of the actuators' parameters is zero (every coefficient below :data:`PARALLEL_TOL`)."""
    import sympy as sp

    expression = sp.sympify(expression)
    values = sp.Poly(sp.expand(expression), *expression.free_symbols).coeffs() if expression.free_symbols \
        else [expression]
    return all(abs(complex(c)) < PARALLEL_TOL for c in values)


def _row_survives_elimination(joint, e, w) -> bool:
    """Whether a leg's orientation row is a polynomial of the unknowns once its last passive joint ``joint`` is
    eliminated as a sphere (:func:`_row_through_sphere`): that joint universal, its second axis and the platform
    joint's first axis ``e`` both across the leg (``w``, from the joint's centre to the platform joint's; both in the
    body after the joint)."""
    import sympy as sp

    return joint.kind == "U" and _vanishes(w.dot(sp.Matrix(joint.axes[1]))) and _vanishes(e.dot(w))


def _row_through_sphere(joint, e, w, rot, d, b, D):
    """The orientation row ``(R_leg e)·(R a₂) = 0`` of a leg whose last passive joint, universal, is eliminated as
    a sphere, without its angles: ``e`` is the platform joint's first axis in the body after that joint, ``w`` the
    joint's centre to the platform joint's in that body, ``rot`` the frame before the joint, ``d = D (p_i − c)``,
    ``b = D R a₂``, ``D`` the Cayley map's denominator.

    When the joint's second axis ``u₂`` is across the leg (``w·u₂ = 0``) the body turns ``u₂`` across both the
    joint's first axis and the leg: ``R_leg u₂ = σ v / |v|`` with ``v = (R u₁) × d`` and a sign ``σ`` (the joint's
    two branches), ``R_leg w = d / D``. So where ``e`` is across the leg too (``e·w = 0``), ``e = α u₂ + γ (u₂ × w)
    / |w|²`` turns to ``σ (α v + γ v × d / (D |w|²)) / |v|``, and the row, times ``|v| D³ |w|²`` and the sign, is
    ``α |w|² D (v·b) + γ (v × d)·b`` — both branches' (as the leg's joints are, the configuration reads one).
    With ``e = u₂`` (each leg's inner axes parallel, every 3-UPU) it is ``v·b``."""
    import sympy as sp

    u2 = sp.Matrix(joint.axes[1])
    v = (rot * sp.Matrix(joint.axes[0])).cross(d)
    alpha, gamma = e.dot(u2), e.dot(u2.cross(w))
    if _vanishes(gamma):
        return v.dot(b)
    square = w.dot(w)
    if _vanishes(alpha):
        return gamma * v.cross(d).dot(b)
    return alpha * square * D * v.dot(b) + gamma * v.cross(d).dot(b)


def _key(description) -> str:
    """The name of what pkmlab keeps of ``description``'s forward kinematics in its cache folder: a digest of its
    TOML form and of :data:`SEED`."""
    import hashlib

    from ..description.spatial import spatial_mechanism_to_toml

    return hashlib.sha1(f"{SEED}\n{spatial_mechanism_to_toml(description)}".encode()).hexdigest()[:20]


@functools.lru_cache(maxsize=16)
def _family(description):
    """The offset family ``F(z; θ) − b`` of ``description`` (module docstring) as a straight-line program of
    ``(z, θ, b)``, both ``θ`` and ``b`` moving; with the number of unknowns and of actuator parameters, the layout
    and the unknowns' names."""
    from ..description.mobility import _size

    equations, unknowns, params, layout = build_system(description)
    name = f"general_fk-{_key(description)}"
    family = homotopy.offset_family(name, equations, unknowns, params, _size(description))
    if layout["rigid"] and family.block is not None and set(family.block.unknowns) == {3, 4, 5}:  # g1, g2, g3
        R0 = _centred_chart(family, layout["R0"])
        equations, unknowns, params, layout = build_system(description, R0)
        family = homotopy.offset_family(f"{name}-centred", equations, unknowns, params, _size(description))
    return family, len(unknowns), len(params), layout, [str(u) for u in unknowns]


#: Rotations :func:`_centred_chart` chooses among.
CHART_CANDIDATES = 2000


def _centred_chart(family, R0: np.ndarray) -> np.ndarray:
    """A centre for the orientation's chart among the solutions of a parameter-free block of the orientation's
    three unknowns: the orientation rows of legs that no actuator turns (a 3-CRR's), whose solutions are the
    same rotations at every actuator value. The chart misses the half turns from its centre, and the rotations
    near them have large ``g``: their equations' terms are large, and monodromy's loops, of the offsets' size,
    hardly move them (a 3-CRR's generic instance came out short). The block's solutions (its total-degree
    homotopy at zero offsets: every one) as rotations; the centre, among :data:`CHART_CANDIDATES` rotations from a
    fixed seed, the one whose largest angle to them is least."""
    ends = homotopy.block_solutions(family.block, np.zeros(len(family.block.equations)))
    real = ends.x[ends.regular & (np.abs(ends.x.imag).max(axis=1) < 1e-9)].real
    if not len(real):
        return R0
    rotations = np.array([_cayley(R0, g) for g in real])
    rng = np.random.default_rng(SEED + 2)
    candidates = np.array([rotation_of_quaternion(e) for e in rng.standard_normal((CHART_CANDIDATES, 4))])
    # the angle of Cᵀ R from its trace; the largest over the block's rotations, least over the candidates
    cosines = (np.einsum("cji,kji->ck", candidates, rotations) - 1.0) / 2.0
    return candidates[int(np.argmax(cosines.min(axis=1)))]


@functools.lru_cache(maxsize=16)
def generic_solutions(description):
    """:func:`solve_generic_instance`, kept in pkmlab's cache folder beside the compiled kernels (keyed by the
    description's TOML form): a later process reads it instead of running monodromy again."""

    def solve():
        solutions, parameters, loops = solve_generic_instance(description)
        return {"solutions": solutions, "parameters": parameters, "loops": np.array(loops)}

    data = homotopy.cached_arrays(
        f"assembly/{_key(description)}", solve, f"{description.name}: solving its forward kinematics at generic "
        "actuator values, once (monodromy, seconds; kept in the cache)")
    return data["solutions"], data["parameters"], int(data["loops"])


#: Most solutions of a machine's offset family that monodromy looks for (the catalogue's have 64 to 80; a machine
#: of six R*RRS legs has thousands, which would take monodromy an hour and every solve seconds).
MAX_GENERIC = 1000


def solve_generic_instance(description):
    """The machine's assembly modes at generic complex actuator parameters ``θ₁`` (cached): the solutions of
    the offset family ``F(z; θ) − b`` (:func:`pkmlab.numerics.homotopy.generic_instance`), monodromy in ``θ``
    alone confirming them; merged with a second instance's, from another seed, carried to ``θ₁`` by a parameter
    homotopy (the module's *Completeness*). Returns ``(solutions, (θ₁, 0), loops)`` (the loops of both). A machine
    whose offset family has more than :data:`MAX_GENERIC` solutions is refused
    (:class:`~pkmlab.errors.AssemblyError`), saying so."""
    family, n, m, _layout, _names = _family(description)
    try:
        solutions, p1, loops = homotopy.generic_instance(family, n, m, np.random.default_rng(SEED),
                                                         max_solutions=MAX_GENERIC)
        other, p2, more = homotopy.generic_instance(family, n, m, np.random.default_rng(SEED + 1),
                                                    max_solutions=MAX_GENERIC)
    except homotopy.TooManySolutions as many:
        raise AssemblyError(
            f"{description.name}: its forward-kinematics system has more than {MAX_GENERIC} complex solutions at "
            f"generic actuator values ({many.count} after {many.loops} monodromy loops; the catalogue's machines "
            "have at most 80), more than pkmlab's general method takes on: every assembly mode of this machine "
            "cannot be listed (inverse kinematics, dynamics and runs from a known configuration do not need "
            "them)") from None
    if len(other):  # the first's solutions are distinct already: merging keeps them, in their order
        ends = homotopy.parameter_homotopy(family, other, p2, p1)
        solutions = homotopy.distinct(np.vstack([solutions, ends.x[ends.regular]]), family.scale)
    return solutions, p1, loops + more


# ------------------------------------------------------------------ solving
def _parameters(description, theta: np.ndarray, n: int) -> np.ndarray:
    values = []
    for leg, t in zip(description.legs, theta, strict=True):
        values += [np.cos(t), np.sin(t)] if leg.joints[leg.actuated].kind == "R" else [t]
    return np.concatenate([np.array(values, dtype=complex), np.zeros(n, dtype=complex)])


def _cayley(R0: np.ndarray, g: np.ndarray) -> np.ndarray:
    skew = np.array([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
    return R0 @ (((1 - g @ g) * np.eye(3) + 2 * np.outer(g, g) + 2 * skew) / (1 + g @ g))


def _configuration(model, theta: np.ndarray, z: np.ndarray, names: list[str], layout: dict) -> np.ndarray | None:
    """The configuration ``q`` of a real solution ``z`` (module docstring), before polishing; None when an
    eliminated universal joint cannot turn its body that way (its own singularity)."""
    from ..description.spatial import leg_frames, orientation_angles
    from ..description.spatial_legs import turn_onto, universal_angles

    m = model.description
    value = dict(zip(names, z, strict=True))
    X = np.array([value["X"], value["Y"], value["Z"]])
    if layout["rigid"]:
        R = _cayley(layout["R0"], np.array([value["g1"], value["g2"], value["g3"]]))
        whole = np.array([*X, *orientation_angles(R)])
    else:
        R, whole = np.eye(3), X
    actuators, passive = [], []
    for i, (leg, (_kind, last, _free)) in enumerate(zip(m.legs, layout["legs"], strict=True)):
        joint_values: dict[int, list[float]] = {leg.actuated: [float(theta[i])]}
        for k, joint in enumerate(leg.joints[:-1]):
            if joint.actuated or k == last:
                continue
            if joint.kind == "P":
                joint_values[k] = [value[f"l{i + 1}_{k + 1}"]]
            else:
                joint_values[k] = [float(np.arctan2(value[f"s{i + 1}_{k + 1}{ab}"], value[f"c{i + 1}_{k + 1}{ab}"]))
                                   for ab in "ab"[:joint.coordinates]]
        if last is not None:
            # the leg's chain with the eliminated joint unturned: its centre, the frame it turns in, and the
            # spherical joint's centre w from it in that frame
            unturned = {**joint_values, last: [0.0] * leg.joints[last].coordinates}
            frames = leg_frames(leg, [v for k in range(len(leg.joints) - 1) for v in unturned[k]])
            centre, rot = frames[last]
            w = rot.T @ (frames[-1][0] - centre)
            target = X + R @ np.array(m.platform.attachments[i])
            local = rot.T @ (target - centre)
            joint = leg.joints[last]
            if joint.kind == "U":
                q1, q2, bad = universal_angles(joint.axes, w, local[None, :])
                if bad[0]:
                    return None
                joint_values[last] = [float(q1[0]), float(q2[0])]
            else:
                joint_values[last] = [float(turn_onto(np.array(joint.axes[0]), w, local[None, :])[0])]
        for k, joint in enumerate(leg.joints[:-1]):
            (actuators if joint.actuated else passive).extend(joint_values[k])
    order = [m.platform.full_pose_names.index(c) for c in m.platform.q_pose_names]
    return np.array([*actuators, *passive, *whole[order]])


#: Largest imaginary part (relative to the machine's size and the solution's) of an endpoint taken as real.
IMAG_TOL = 1e-7


#: Solves along a detour through generic complex parameters after a solve whose paths were not all clean.
DETOURS = 2


def _reach(description) -> float:
    """A bound of the distance of the platform's tracked point from the origin at any real configuration: the
    farthest base point, plus the leg's bodies and its slides' strokes, plus the farthest attachment; infinite
    where a slide has no stroke."""
    bound = 0.0
    for leg in description.legs:
        slide = 0.0
        for k, joint in enumerate(leg.joints[:-1]):
            if joint.kind == "P":
                if k != leg.actuated or leg.stroke is None:  # (the stroke is the leg's own actuator's)
                    return np.inf
                slide += max(abs(v) for v in leg.stroke)
        bound = max(bound, float(np.linalg.norm(leg.base)) + slide
                    + sum(float(np.linalg.norm(b.tip)) for b in leg.bodies))
    return bound + max(float(np.linalg.norm(a)) for a in description.platform.attachments)


#: A path stopped short of the target with its tracked point this many times :func:`_reach` away is taken as a
#: path to infinity (a solution of the generic instance with none at the target, no real assembly mode).
ESCAPED = 100.0


def _escaped(ends, names: list[str], reach: float):
    """``ends`` with the paths that stopped far beyond the machine's reach (:data:`ESCAPED`) marked as diverged."""
    position = [names.index(c) for c in ("X", "Y", "Z")]
    far = ~ends.reached & (np.abs(ends.x[:, position]).max(axis=1) > ESCAPED * reach)
    return ends._replace(diverged=ends.diverged | far, reached=ends.reached | far)


def _imaginary(z: np.ndarray, scale: float) -> np.ndarray:
    """The largest imaginary part of each endpoint (P, n), relative to its size and the machine's."""
    size = np.maximum(np.abs(z).max(axis=1, initial=0.0), 1.0) * max(scale, 1.0)
    return np.abs(z.imag).max(axis=1, initial=0.0) / size


def _jumped(ends, scale: float) -> int:
    """How many paths ended at a regular solution another path had reached (a path jumped)."""
    x = ends.x[ends.regular]
    return len(x) - len(homotopy.distinct(x, scale))


def general_assembly_modes(model, theta) -> GeneralAssembly:
    """The real endpoints of the parameter homotopy of ``model`` at actuator values ``theta`` as configurations
    (module docstring), before Newton's method polishes them on ``η = 0``
    (:func:`pkmlab.algorithms.assembly.assembly_modes` does, and merges repeats).

    A solve in which a path stopped short of the target (it met a near-singularity on its way, or a solution
    far out in the orientation's chart), jumped onto another path's solution or went to infinity is repeated
    along a detour — from the generic solutions to generic complex parameters, then to the target — which
    takes every path along another way (at most :data:`DETOURS` times). The solve is complete when an attempt
    ended every path at a distinct regular solution, when the attempts together found as many distinct regular
    solutions as there are paths (a target has no more isolated solutions than a generic instance), or when a
    detour whose every path reached the target found no solution the attempts before it had not (a path that
    jumped onto a path to infinity is seen by no single attempt); otherwise what the last attempt left unsure
    is reported."""
    m = model.description
    theta = np.asarray(theta, dtype=float)
    family, n, _m, layout, names = _family(m)
    sols, p_generic, loops = generic_solutions(m)
    target = _parameters(m, theta, n)
    reach = _reach(m)
    ends = _escaped(homotopy.parameter_homotopy(family, sols, p_generic, target), names, reach)
    attempts, lost = [ends], 0  # lost: paths of the last detour that failed on its way to the generic point
    rng = np.random.default_rng(SEED + 1)

    def distinct_regular(group) -> int:
        return len(homotopy.distinct(np.concatenate([e.x[e.regular] for e in group]), family.scale))

    def complete() -> bool:
        settled = not lost and ends.reached.all() and not _jumped(ends, family.scale)
        if settled and not ends.diverged.any():
            return True
        if distinct_regular(attempts) == len(sols):
            return True
        return settled and len(attempts) > 1 and distinct_regular(attempts) == distinct_regular(attempts[:-1])

    done = complete()
    while not done and len(attempts) <= DETOURS:
        via = p_generic + (rng.standard_normal(len(p_generic)) + 1j * rng.standard_normal(len(p_generic))) \
            * np.maximum(np.abs(p_generic), 1.0)
        middle = homotopy.parameter_homotopy(family, sols, p_generic, via)
        ends = _escaped(homotopy.parameter_homotopy(family, middle.x[middle.regular], via, target), names, reach)
        lost = len(sols) - len(ends.x)
        attempts.append(ends)
        done = complete()
    found = []
    for e in attempts:
        real = np.isfinite(e.x).all(axis=1) & ~e.diverged & e.reached & (_imaginary(e.x, family.scale) <= IMAG_TOL)
        for k in np.flatnonzero(real):
            q = _configuration(model, theta, e.x[k].real, names, layout)
            if q is not None:
                found.append(q)
    if done:
        return GeneralAssembly(found, len(sols), 0, 0, loops)
    # a singular endpoint far from the reals is no missing real assembly mode: only the near-real ones are doubts
    singular = ~ends.regular & ~ends.diverged & ends.reached & (_imaginary(ends.x, family.scale) < 1e-4)
    failed = lost + int(np.sum(~ends.reached)) + _jumped(ends, family.scale)
    return GeneralAssembly(found, len(sols), failed, int(np.sum(singular)), loops)
