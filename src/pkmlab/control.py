"""Controllers: computed torque (feedback linearisation, paper §4, eqs. 36–41) and joint PD.

A controller gives the actuator torques ``τ`` from the time and the measured ``(θ, θ̇)``,
given the desired motion ``(θ_d, θ̇_d, θ̈_d)``. The computed-torque controller uses its *own*
model of the manipulator, which may differ from the plant's; it recovers its passive
variables by branch-following forward kinematics from the measured ``θ`` (paper figure 2)::

    e = θ - θ_d,   τ = M̂θ (θ̈_d - kp e - kv ė) + Ĉθ θ̇       (eqs. 36–39, SPEC §5)

with critical damping ``kv = 2√kp`` by default (eq. 41).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from ._compile_cache import NO_REFCOUNT
from .errors import InvalidParameterError
from .mechanisms import rrr3

COMPUTED_TORQUE = 0
PD = 1
CONTROLLER_TYPES = {"computed_torque": COMPUTED_TORQUE, "pd": PD}


@dataclass(frozen=True)
class ControllerSpec:
    """Which controller and its gains. ``kind`` is ``"computed_torque"`` or ``"pd"``.

    For computed torque ``kp`` (1/s²) and ``kv`` (1/s) shape the error dynamics
    ``ë + kv ė + kp e = 0``; for the PD law ``τ = -kp e - kv ė`` they are in N·m/rad and
    N·m·s/rad. ``kv`` defaults to ``2√kp`` (critical damping of the linearised loop).
    """

    kind: str = "computed_torque"
    kp: float = 1000.0
    kv: float | None = None

    def __post_init__(self):
        if self.kind not in CONTROLLER_TYPES:
            raise InvalidParameterError(f"controller type must be one of {sorted(CONTROLLER_TYPES)}, got {self.kind!r}")
        for name in ("kp", "kv"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise InvalidParameterError(f"controller {name} must be a non-negative number, got {value!r}")

    @property
    def velocity_gain(self) -> float:
        return 2.0 * math.sqrt(self.kp) if self.kv is None else float(self.kv)


@njit(**NO_REFCOUNT)
def control_torque(kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, min_abs_s, ws, tau):
    """Torques ``τ`` (written into ``tau``) of one controller evaluation; returns the status.

    ``ws`` is the controller's own :class:`~pkmlab.mechanisms.rrr3.Workspace` (model ``P``): its
    ``BASE`` slot holds the controller's configuration at the previous evaluation, from which
    branch following reaches the measured ``θ``; on success the new configuration becomes the
    base. The status is that of the controller's branch following.
    """
    e0 = rrr3.wrap_angle(theta[0] - theta_d[0])
    e1 = rrr3.wrap_angle(theta[1] - theta_d[1])
    e2 = rrr3.wrap_angle(theta[2] - theta_d[2])
    if kind == PD:
        tau[0] = -kp * e0 - kv * (theta_dot[0] - theta_dot_d[0])
        tau[1] = -kp * e1 - kv * (theta_dot[1] - theta_dot_d[1])
        tau[2] = -kp * e2 - kv * (theta_dot[2] - theta_dot_d[2])
        return rrr3.OK
    tau[:] = 0.0
    status = rrr3.follow_branch(ws, theta, P, min_abs_s)
    if status != rrr3.OK:
        return status
    rrr3.copy_slot(ws, rrr3.TRIAL_SLOT, rrr3.BASE_SLOT)
    rrr3.evaluate_dynamics(ws, rrr3.BASE_SLOT, theta_dot, P)
    # v = θ̈_d - kp e - kv ė (eq. 38), τ = M̂θ v + Ĉθ θ̇ (eq. 39)
    v0 = theta_ddot_d[0] - kp * e0 - kv * (theta_dot[0] - theta_dot_d[0])
    v1 = theta_ddot_d[1] - kp * e1 - kv * (theta_dot[1] - theta_dot_d[1])
    v2 = theta_ddot_d[2] - kp * e2 - kv * (theta_dot[2] - theta_dot_d[2])
    m = ws.m_theta
    for i in range(3):
        tau[i] = ws.c_theta[i] + m[i, 0] * v0 + m[i, 1] * v1 + m[i, 2] * v2
    return rrr3.OK
