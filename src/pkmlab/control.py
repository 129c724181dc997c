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

import numpy as np
from numba import njit

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


@njit(cache=True)
def control_torque(kind, kp, kv, q_ctrl_prev, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, min_abs_s,
                   q_ctrl_out):
    """Torques of one controller evaluation; ``q_ctrl_out`` receives the controller's configuration.

    Returns ``(τ, status)``; status is that of the controller's branch following.
    """
    tau = np.zeros(3)
    e = np.empty(3)
    e_dot = np.empty(3)
    for i in range(3):
        e[i] = rrr3.wrap_angle(theta[i] - theta_d[i])
        e_dot[i] = theta_dot[i] - theta_dot_d[i]
    if kind == PD:
        q_ctrl_out[:] = q_ctrl_prev
        for i in range(3):
            tau[i] = -kp * e[i] - kv * e_dot[i]
        return tau, rrr3.OK
    status = rrr3.branch_following(q_ctrl_prev, theta, P, q_ctrl_out, min_abs_s)
    if status != rrr3.OK:
        return tau, status
    m_theta, c_theta, _qd, ok = rrr3.actuator_space_dynamics(q_ctrl_out, theta_dot, P)
    if not ok:
        return tau, rrr3.SINGULAR
    v = np.empty(3)
    for i in range(3):
        v[i] = theta_ddot_d[i] - kp * e[i] - kv * e_dot[i]
    for i in range(3):
        tau[i] = c_theta[i] + m_theta[i, 0] * v[0] + m_theta[i, 1] * v[1] + m_theta[i, 2] * v[2]
    return tau, rrr3.OK
