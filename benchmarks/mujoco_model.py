"""The paper's 3-RRR as a MuJoCo model, for a speed benchmark and an accuracy comparison with pkmlab.

MuJoCo simulates kinematic *trees*; a closed chain is a spanning tree plus equality
constraints that close its loops. For the 3-RRR (conventions §1):

* the tree holds the three legs, each an actuated hinge ``theta_i`` at its base point ``b_i``
  (axis z), the proximal link ``l_i``, the passive elbow hinge ``elbow_i`` and the distal link
  ``r_i``; the platform hangs on leg 1's distal link through a seventh hinge ``platform`` at
  ``p1``: 7 hinge joints;
* legs 2 and 3 are closed onto the platform by two ``<equality><connect>`` constraints
  between a site at the tip of distal link ``i`` and a site at platform vertex ``P_i``
  (2 loops; a ``connect`` is 3 scalar rows, its z row is identically satisfied in the plane).

MuJoCo's joint angles are *relative* (each hinge turns its body with respect to its parent),
pkmlab's are absolute (conventions §1): ``qpos = (θ1, φ1 - θ1, α - φ1, θ2, φ2 - θ2, θ3, φ3 - θ3)`` in
the tree order :data:`JOINT_NAMES`; :func:`qpos_from_q` is that linear map (it maps the rates
``q̇`` to ``qvel`` as well).

Masses, mass-centre offsets and moments of inertia about the mass centre are those pkmlab's
dynamics reads (:func:`pkmlab.paper.rrr3.body_description`): every body's mass centre
is a fixed vector in its own frame (x axis along the link, or along ``p1 → p2`` for the
platform), so MuJoCo's ``<inertial pos=...>`` takes it unchanged. No gravity (horizontal
plane), no joint damping, armature or friction loss, contacts disabled; three ``motor``
actuators (gear 1, unlimited) on the base hinges; RK4 at 1 ms.

Constraint settings
-------------------
MuJoCo's constraints are soft: on the constraint manifold the constraint-space acceleration
is ``a = R (A + R)⁻¹ a_unconstrained`` with the regulariser ``R = (1 - d)/d · Â``, so the
acceleration error relative to the exact (rigid) closed chain is of order ``(1 - d)/d``,
``d`` being the impedance ``solimp[0]`` (at zero violation).

* ``stiff=True``: ``solimp = (0.9999, 0.9999, 0.001, 0.5, 2)``: the impedance at MuJoCo's cap
  ``mjMAXIMP = 0.9999`` (larger values are clamped to it), and ``solref = (0.002, 1)``: time
  constant 2 ms, twice the time step, the smallest MuJoCo accepts with its ``refsafe`` check
  on, critical damping. The time constant does not change the acceleration error at a
  consistent state; it sets how stiffly the reference acceleration pulls a violation back.
  Replaying the nominal case open loop, 2 ms gives the smallest deviation from pkmlab's
  plant: with ``refsafe`` disabled, 1 ms and 0.5 ms are still stable but ~10x and ~1000x
  less accurate (RK4 resolves the constraint spring poorly), 0.2 ms diverges; 5 ms is
  about as accurate, 20 ms (the default) 25x worse.
  ``Â`` is MuJoCo's estimate of the diagonal of ``A = J M⁻¹ Jᵀ`` made at ``qpos0`` (the
  straight-legs layout). The ``diagexact`` flag (exact diagonal at the current configuration)
  was tried and left off: here it gives a larger ``R``, i.e. softer constraints (largest
  acceleration error 5.6e-4 instead of 1.1e-4 over 50 states of the nominal path).
* ``stiff=False``: MuJoCo's defaults, ``solimp = (0.9, 0.95, 0.001, 0.5, 2)``,
  ``solref = (0.02, 1)``.

Solver: Newton (MuJoCo's default), ``tolerance = 1e-10``, ``iterations = 50``. With
equality constraints only, the problem is an unconstrained quadratic and Newton solves it
in one iteration, so these settings cost nothing and do not hide solver error.

Run ``python benchmarks/mujoco_model.py`` for the figures (timing of the paper's nominal case
replayed open loop, acceleration errors, deviation from pkmlab's plant).
"""

from __future__ import annotations

import gc
import statistics
import time

import mujoco
import numpy as np

import pkmlab
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.paper import dynamics as pk_dynamics
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR

#: MuJoCo's hinge joints in tree order (the order of ``qpos``/``qvel``).
JOINT_NAMES = ("theta1", "elbow1", "platform", "theta2", "elbow2", "theta3", "elbow3")

#: ``qpos = RELATIVE @ q`` for pkmlab's ``q = (θ1, θ2, θ3, φ1, φ2, φ3, α)``.
RELATIVE = np.array(
    [
        [1, 0, 0, 0, 0, 0, 0],  # theta1 = θ1
        [-1, 0, 0, 1, 0, 0, 0],  # elbow1 = φ1 - θ1
        [0, 0, 0, -1, 0, 0, 1],  # platform = α - φ1
        [0, 1, 0, 0, 0, 0, 0],  # theta2 = θ2
        [0, -1, 0, 0, 1, 0, 0],  # elbow2 = φ2 - θ2
        [0, 0, 1, 0, 0, 0, 0],  # theta3 = θ3
        [0, 0, -1, 0, 0, 1, 0],  # elbow3 = φ3 - θ3
    ],
    dtype=float,
)
RELATIVE.setflags(write=False)

#: Indices of the actuated joints ``θ1, θ2, θ3`` in ``qpos``/``qvel``.
ACTUATED = (0, 3, 5)

STIFF_SOLREF = (0.002, 1.0)
STIFF_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
SOLVER_TOLERANCE = 1e-10
SOLVER_ITERATIONS = 50
TIMESTEP = 1e-3


def _f(x) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(x))


def mjcf_from_model(model: Planar3RRR, *, stiff: bool = True) -> str:
    """MJCF XML of ``model``: three legs in a tree, the platform on leg 1, two ``connect`` loops.

    ``stiff`` selects the constraint settings (see the module docstring): the stiffest stable
    ones at 1 ms, or MuJoCo's defaults.
    """
    b, l, r = model.base_points, model.active_lengths, model.passive_lengths
    verts = model.platform_vertices
    width = 0.01  # visual only: geoms have no mass (inertiafromgeom="false") and no contacts

    def inertial(mass, com, izz):
        # Hinges about z only: ixx, iyy never enter the dynamics; "I I I" satisfies MuJoCo's
        # triangle inequality for inertias.
        return (f'<inertial pos="{_f(com)} 0" mass="{float(mass)!r}" '
                f'diaginertia="{_f([izz, izz, izz])}"/>')

    legs = []
    for i in range(3):
        distal_tip = f'<site name="tip{i + 1}" pos="{float(r[i])!r} 0 0"/>'
        platform = ""
        if i == 0:
            ref = model.reference_point
            platform = f"""
          <body name="platform" pos="{float(r[0])!r} 0 0">
            <joint name="platform"/>
            {inertial(model.platform_mass, model.platform_com, model.platform_inertia)}
            <geom type="box" size="{model.platform_side / 2!r} {model.platform_side / 4!r} {width / 2!r}"
                  pos="{_f(ref)} 0"/>
            <site name="vertex2" pos="{_f(verts[1])} 0"/>
            <site name="vertex3" pos="{_f(verts[2])} 0"/>
            <site name="centroid" pos="{_f(ref)} 0"/>
          </body>"""
        legs.append(f"""
    <body name="proximal{i + 1}" pos="{_f(b[i])} 0">
      <joint name="theta{i + 1}"/>
      {inertial(model.active_masses[i], model.active_com[i], model.active_inertias[i])}
      <geom type="capsule" fromto="0 0 0 {float(l[i])!r} 0 0" size="{width!r}"/>
      <body name="distal{i + 1}" pos="{float(l[i])!r} 0 0">
        <joint name="elbow{i + 1}"/>
        {inertial(model.passive_masses[i], model.passive_com[i], model.passive_inertias[i])}
        <geom type="capsule" fromto="0 0 0 {float(r[i])!r} 0 0" size="{width!r}"/>
        {distal_tip}{platform}
      </body>
    </body>""")
    if stiff:
        eq_params = f'solref="{_f(STIFF_SOLREF)}" solimp="{_f(STIFF_SOLIMP)}"'
    else:
        eq_params = ""
    motors = "\n".join(f'    <motor name="tau{i}" joint="theta{i}" gear="1" ctrllimited="false"/>' for i in (1, 2, 3))
    return f"""<mujoco model="planar_3rrr">
  <compiler angle="radian" inertiafromgeom="false"/>
  <option timestep="{TIMESTEP!r}" integrator="RK4" gravity="0 0 0" solver="Newton"
          tolerance="{SOLVER_TOLERANCE!r}" iterations="{SOLVER_ITERATIONS}">
    <flag contact="disable"/>
  </option>
  <default>
    <joint type="hinge" axis="0 0 1" damping="0" armature="0" frictionloss="0" limited="false"/>
    <geom contype="0" conaffinity="0" mass="0"/>
  </default>
  <worldbody>{"".join(legs)}
  </worldbody>
  <equality>
    <connect name="loop1" site1="vertex2" site2="tip2" {eq_params}/>
    <connect name="loop2" site1="vertex3" site2="tip3" {eq_params}/>
  </equality>
  <actuator>
{motors}
  </actuator>
</mujoco>
"""


def build(model: Planar3RRR, *, stiff: bool = True) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Compile :func:`mjcf_from_model` and check its joint order against :data:`JOINT_NAMES`."""
    m = mujoco.MjModel.from_xml_string(mjcf_from_model(model, stiff=stiff))
    names = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt))
    if names != JOINT_NAMES or not np.array_equal(m.jnt_qposadr, np.arange(7)):
        raise RuntimeError(f"unexpected MuJoCo joint layout {names}")
    return m, mujoco.MjData(m)


def qpos_from_q(q) -> np.ndarray:
    """MuJoCo ``qpos`` (relative angles, :data:`JOINT_NAMES` order) from pkmlab's ``q`` (..., 7).

    The map is linear, so it also turns pkmlab's rates ``q̇`` into MuJoCo's ``qvel``.
    """
    return np.asarray(q, dtype=float) @ RELATIVE.T


def q_from_qpos(qpos) -> np.ndarray:
    """pkmlab's absolute ``q`` (..., 7) from MuJoCo's ``qpos`` (inverse of :func:`qpos_from_q`)."""
    return np.asarray(qpos, dtype=float) @ np.linalg.inv(RELATIVE).T


def set_state(m: mujoco.MjModel, d: mujoco.MjData, model: Planar3RRR, q, theta_dot, tau=None) -> None:
    """Put MuJoCo at pkmlab's state: configuration ``q`` (7,), actuated rates ``θ̇`` (3,), torques ``τ``.

    ``q`` must lie on the constraint manifold; the passive rates are pkmlab's
    ``Jqθ θ̇`` (:func:`kin.coordinate_rates`), so that the velocity is consistent too.
    """
    mujoco.mj_resetData(m, d)
    d.qpos[:] = qpos_from_q(q)
    d.qvel[:] = qpos_from_q(kin.coordinate_rates(model, q, theta_dot))
    d.ctrl[:] = 0.0 if tau is None else tau


def platform_pose(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """``(x, y, α)`` of the platform (centroid and angle) after ``mj_kinematics``."""
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "centroid")
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "platform")
    xmat = d.xmat[body].reshape(3, 3)
    return np.array([d.site_xpos[site, 0], d.site_xpos[site, 1], np.arctan2(xmat[1, 0], xmat[0, 0])])


def connect_residual(m: mujoco.MjModel, d: mujoco.MjData) -> float:
    """Largest distance (m) between the two sites of a ``connect`` constraint (after ``mj_kinematics``)."""
    worst = 0.0
    for e in range(m.neq):
        s1, s2 = m.eq_obj1id[e], m.eq_obj2id[e]
        worst = max(worst, float(np.linalg.norm(d.site_xpos[s1] - d.site_xpos[s2])))
    return worst


def mujoco_theta_ddot(model: Planar3RRR, q, theta_dot, tau, *, stiff: bool = True) -> np.ndarray:
    """MuJoCo's actuated accelerations ``θ̈`` (n, 3) (``mj_forward`` ``qacc``) at pkmlab states (n, ·)."""
    m, d = build(model, stiff=stiff)
    q, theta_dot, tau = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, theta_dot, tau))
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        set_state(m, d, model, q[k], theta_dot[k], tau[k])
        mujoco.mj_forward(m, d)
        out[k] = d.qacc[list(ACTUATED)]
    return out


def acceleration_error(model: Planar3RRR, q, theta_dot, tau, *, stiff: bool = True) -> float:
    """Largest relative error ``‖θ̈_MuJoCo - θ̈_pkmlab‖ / ‖θ̈_pkmlab‖`` over the states (norm-wise).

    ``q`` (n, 7) on the manifold (actuated and passive angles), ``theta_dot`` (n, 3),
    ``tau`` (n, 3); the reference is pkmlab's exact :func:`paper_dynamics.forward_dynamics`.
    """
    exact = pk_dynamics.forward_dynamics(model, q, theta_dot, tau)
    got = mujoco_theta_ddot(model, q, theta_dot, tau, stiff=stiff)
    exact = np.atleast_2d(exact)
    return float(np.max(np.linalg.norm(got - exact, axis=1) / np.linalg.norm(exact, axis=1)))


def random_states(model: Planar3RRR, q_path, n: int, seed: int = 1) -> tuple[np.ndarray, ...]:
    """``n`` states at configurations drawn from ``q_path`` with random ``θ̇`` (rad/s) and ``τ`` (N·m), ~N(0, 1)."""
    rng = np.random.default_rng(seed)
    q = np.asarray(q_path)[rng.choice(len(q_path), size=n, replace=False)]
    return q, rng.normal(size=(n, 3)), rng.normal(size=(n, 3))


def paper_plant(result: pkmlab.SimulationResult) -> tuple[Planar3RRR, np.ndarray]:
    """A run's plant in the paper's own formulation (:class:`~pkmlab.paper.geometry.Planar3RRR`, which the MJCF and the
    reference dynamics read) and the run's configurations in its 7 coordinates ``(θ, φ, α)``.

    The simulation's machine is a :class:`~pkmlab.model.mechanism_model.MechanismModel` in 9 coordinates
    ``(θ, φ, x, y, α)``; it must be the paper's 3-RRR (its parameters the same to rounding).
    """
    plant, paper = result.scenario.plant_model, Planar3RRR.paper()
    reference = MechanismModel.from_3rrr(paper)
    if plant.kernels is not reference.kernels or not np.allclose(reference.P, plant.P, rtol=1e-12, atol=1e-15):
        raise ValueError(f"the run's plant ({plant.description.notation}) is not the paper's 3-RRR")
    return paper, kin.coordinates_to_3rrr(np.asarray(result.q, dtype=float))


def _timings(fn, repeats: int) -> tuple[float, float]:
    """``(median, min)`` wall time (s) of ``fn()`` over ``repeats`` runs after a warm-up, gc off."""
    fn()
    times = []
    enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
    finally:
        if enabled:
            gc.enable()
    return statistics.median(times), min(times)


def time_nominal_case(repeats: int = 7, *, stiff: bool = True, result: pkmlab.SimulationResult | None = None) -> dict:
    """Replay the nominal case's torques open loop in MuJoCo (RK4, 1 ms); time it, compare with pkmlab.

    pkmlab's closed-loop run (:func:`pkmlab.simulate` of ``paper_scenario("nominal")``) gives
    the initial state (at rest) and the torques ``τ_k`` held over each 1 ms sample. MuJoCo
    takes one step per sample interval with ``ctrl = τ_k`` (1,572 samples ``t = 0 … T``, so
    1,571 steps); its state after step ``k`` is compared with pkmlab's sample ``k + 1``.
    Timed: a Python loop of ``mj_step`` and, if available, ``mujoco.rollout`` (one call, no
    Python per step). Medians (and best) of ``repeats`` runs after a warm-up, gc off.

    Returns the timings, the MuJoCo version, the largest deviations of MuJoCo's replay from
    pkmlab's plant at the samples (actuated angles, platform centroid and angle) and the
    largest ``connect`` residual (m) during the replay.
    """
    if result is None:
        result = pkmlab.simulate(pkmlab.paper_scenario("nominal"))
    model, q = paper_plant(result)
    m, d = build(model, stiff=stiff)
    n_steps = len(result.t) - 1
    ctrl = np.ascontiguousarray(result.tau[:n_steps])
    set_state(m, d, model, q[0], result.theta_dot[0])
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)

    def python_loop(record=None):
        mujoco.mj_setState(m, d, state0, spec)
        for k in range(n_steps):
            d.ctrl[:] = ctrl[k]
            mujoco.mj_step(m, d)
            if record is not None:
                record(k)

    # The replay itself, with deviations recorded after each step (not timed).
    qpos = np.empty((n_steps, 7))
    pose = np.empty((n_steps, 3))
    residual = np.empty(n_steps)

    def record(k):
        qpos[k] = d.qpos
        pose[k] = platform_pose(m, d)
        residual[k] = connect_residual(m, d)

    python_loop(record)  # after mj_step, xpos/site_xpos belong to the last RK4 stage: refresh them
    m_check, d_check = build(model, stiff=stiff)
    for k in range(n_steps):
        d_check.qpos[:] = qpos[k]
        mujoco.mj_kinematics(m_check, d_check)
        pose[k] = platform_pose(m_check, d_check)
        residual[k] = connect_residual(m_check, d_check)
    # MuJoCo after step k  <->  pkmlab's sample k + 1
    theta_dev = np.abs(qpos[:, list(ACTUATED)] - q[1:, :3]).max()
    xy_dev = np.hypot(*(pose[:, :2] - result.pose[1:, :2]).T).max()
    alpha_dev = np.abs(np.angle(np.exp(1j * (pose[:, 2] - result.pose[1:, 2])))).max()

    loop_s, loop_min = _timings(python_loop, repeats)
    figures = {
        "mujoco_version": mujoco.__version__,
        "stiff": stiff,
        "steps": n_steps,
        "timestep_s": m.opt.timestep,
        "python_loop_ms": loop_s * 1e3,
        "python_loop_us_per_step": loop_s / n_steps * 1e6,
        "python_loop_min_ms": loop_min * 1e3,
        "max_theta_deviation_rad": float(theta_dev),
        "max_centroid_deviation_m": float(xy_dev),
        "max_alpha_deviation_rad": float(alpha_dev),
        "max_connect_residual_m": float(residual.max()),
    }
    try:
        from mujoco import rollout
    except ImportError:  # older MuJoCo without the rollout module
        return figures
    controls = ctrl[None]  # (nbatch=1, nstep, nu)
    init = state0[None]
    state_out = np.empty((1, n_steps, state0.size))

    def run_rollout():
        # One call for the whole replay on the calling thread (nbatch = 1); the shape checks the
        # wrapper does once per call are included (tens of µs against ~30 ms of stepping).
        rollout.rollout(m, d, init, controls, state=state_out)

    run_rollout()
    qpos_adr = 1  # mjSTATE_FULLPHYSICS starts with time, then qpos
    if not np.allclose(state_out[0, :, qpos_adr:qpos_adr + 7], qpos, rtol=0, atol=1e-12):
        raise RuntimeError("mujoco.rollout does not reproduce the mj_step loop")
    rollout_s, rollout_min = _timings(run_rollout, repeats)
    figures["rollout_ms"] = rollout_s * 1e3
    figures["rollout_us_per_step"] = rollout_s / n_steps * 1e6
    figures["rollout_min_ms"] = rollout_min * 1e3
    return figures


def main() -> None:
    """Print the figures: accelerations (stiff and default constraints), then the timed replay."""
    result = pkmlab.simulate(pkmlab.paper_scenario("nominal"))
    model, q = paper_plant(result)
    states = random_states(model, q, 50)
    print(f"MuJoCo {mujoco.__version__}, 3-RRR with 7 hinges and 2 connect loops, RK4 at 1 ms")
    print("max relative error of theta_ddot vs paper_dynamics.forward_dynamics (50 states on the nominal path):")
    for stiff in (True, False):
        label = "stiff  " if stiff else "default"
        print(f"  {label}: {acceleration_error(model, *states, stiff=stiff):.3e}")
    for stiff in (True, False):
        fig = time_nominal_case(stiff=stiff, result=result)
        print(f"nominal case replayed open loop, {'stiff' if stiff else 'default'} constraints, {fig['steps']} steps:")
        print(f"  python mj_step loop: {fig['python_loop_ms']:.2f} ms ({fig['python_loop_us_per_step']:.2f} us/step, "
              f"median; best {fig['python_loop_min_ms']:.2f} ms)")
        if "rollout_ms" in fig:
            print(f"  mujoco.rollout:      {fig['rollout_ms']:.2f} ms ({fig['rollout_us_per_step']:.2f} us/step, "
                  f"median; best {fig['rollout_min_ms']:.2f} ms)")
        print(f"  deviation from pkmlab's plant: theta {fig['max_theta_deviation_rad']:.2e} rad, "
              f"centroid {fig['max_centroid_deviation_m']:.2e} m, alpha {fig['max_alpha_deviation_rad']:.2e} rad")
        print(f"  max connect residual: {fig['max_connect_residual_m']:.2e} m")


if __name__ == "__main__":
    main()
