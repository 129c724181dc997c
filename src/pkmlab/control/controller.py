"""Controllers: computed torque (feedback linearisation, paper §4, eqs. 36–41) and joint PD.

A controller gives the actuator torques ``τ`` from the time and the measured ``(θ, θ̇)``,
given the desired motion ``(θ_d, θ̇_d, θ̈_d)``. The computed-torque controller uses its *own*
model of the manipulator, which may differ from the plant's; it recovers its passive
variables by branch-following forward kinematics from the measured ``θ`` (paper figure 2)::

    e = θ - θ_d,   τ = M̂θ (θ̈_d - kp e - kv ė) + Ĉθ θ̇       (eqs. 36–39, conventions §5)

with critical damping ``kv = 2√kp`` by default (eq. 41). The law is compiled once for every mechanism,
with gravity compensation, as :func:`pkmlab.codegen.core.control.control_effort`.

Under sampled-data control (zero-order hold) the gains and the sample time together decide
whether the loop is stable: :func:`sampled_data_spectral_radius` gives the growth factor per
sample of the joint error, :func:`largest_stable_kp` and :func:`largest_stable_sample_time` the
limits, and :mod:`pkmlab.simulation.run` refuses an unstable scenario before running it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import as_real
from ..errors import InvalidParameterError, shown

COMPUTED_TORQUE = 0
PD = 1
CONTROLLER_TYPES = {"computed_torque": COMPUTED_TORQUE, "pd": PD}
#: How a redundantly actuated machine's controller distributes its efforts in a run (the compiled loop's
#: ``distribute``), the rules of :func:`pkmlab.distribute_efforts`.
RUN_DISTRIBUTIONS = ("minimum_norm", "weighted", "minimum_peak", "preload")


@dataclass(frozen=True)
class ControllerSpec:
    """Which controller and its gains.

    For computed torque ``kp`` (1/s²) and ``kv`` (1/s) shape the error dynamics
    ``ë + kv ė + kp e = 0``; for the PD law ``τ = -kp e - kv ė`` they are in N·m/rad and
    N·m·s/rad (N/m and N·s/m for a prismatic actuator). ``kv`` defaults to ``2√kp`` (critical damping of the
    linearised loop).

    Parameters
    ----------
    kind : {"computed_torque", "pd"}
        The control law (default ``"computed_torque"``).
    kp : float
        The proportional gain, non-negative (default 1000).
    kv : float or None
        The derivative gain, non-negative; None for ``2√kp`` (:attr:`velocity_gain`).
    distribution : {"minimum_norm", "weighted", "minimum_peak", "preload"}
        How a redundantly actuated machine's controller shares the force on its pose among its actuators
        (:data:`RUN_DISTRIBUTIONS`): the least 2-norm of the efforts, the least ``Σ w_i τ_i²``, the least largest
        effort ``max |τ_i|`` (for one actuator beyond the degrees of freedom), or the least 2-norm plus the
        internal part of a preload (antagonistic efforts that move nothing). A machine of as many actuators as
        degrees of freedom has one solution: keep ``"minimum_norm"``.
    weights : sequence of float or None
        The weights ``w_i > 0`` of ``"weighted"``, one per actuator (given with it only).
    preload : sequence of float or None
        The preload of ``"preload"``, one effort per actuator (given with it only).

    Raises
    ------
    InvalidParameterError
        If ``kind`` is neither law, a gain is negative or not a finite number, or the distribution is not one of
        :data:`RUN_DISTRIBUTIONS`, lacks its weights or preload, or is given those of another.

    Examples
    --------
    >>> from pkmlab import ControllerSpec
    >>> spec = ControllerSpec(kp=400.0)
    >>> spec.kind, spec.velocity_gain
    ('computed_torque', 40.0)
    >>> ControllerSpec("pd", kp=50.0, kv=2.0).velocity_gain
    2.0
    """

    kind: str = "computed_torque"
    kp: float = 1000.0
    kv: float | None = None
    distribution: str = "minimum_norm"
    weights: tuple | None = None
    preload: tuple | None = None

    def __post_init__(self):
        if not isinstance(self.kind, str) or self.kind not in CONTROLLER_TYPES:
            raise InvalidParameterError(f"controller kind must be one of {sorted(CONTROLLER_TYPES)}, "
                                        f"got {shown(self.kind)}")
        as_real("controller kp", self.kp, "non-negative")
        if self.kv is not None:
            as_real("controller kv", self.kv, "non-negative")
        if not isinstance(self.distribution, str) or self.distribution not in RUN_DISTRIBUTIONS:
            raise InvalidParameterError(f"controller distribution must be one of {list(RUN_DISTRIBUTIONS)}, got "
                                        f"{shown(self.distribution)}")
        for name, method, sign in (("weights", "weighted", "positive"), ("preload", "preload", "finite")):
            value = getattr(self, name)
            if (value is None) == (self.distribution == method):
                raise InvalidParameterError(f"controller {name}: " + (f"needed by distribution '{method}'"
                                            if value is None else f"given for distribution '{method}' only, not "
                                            f"'{self.distribution}'"))
            if value is not None:
                try:
                    numbers = tuple(as_real(f"controller {name}[{i}]", v, sign) for i, v in enumerate(value))
                except TypeError:
                    raise InvalidParameterError(f"controller {name} must be one number per actuator, got "
                                                f"{shown(value)}") from None
                object.__setattr__(self, name, numbers)

    @property
    def velocity_gain(self) -> float:
        """The derivative gain in use: ``kv``, or ``2√kp`` where ``kv`` is None (1/s, or N·m·s/rad for the PD law)."""
        return 2.0 * math.sqrt(self.kp) if self.kv is None else float(self.kv)


#: Spectral radii above ``1 + STABILITY_TOLERANCE`` are unstable; the tolerance absorbs the
#: round-off of marginal loops (``kp = 0``: a double or simple eigenvalue at exactly 1).
STABILITY_TOLERANCE = 1e-9


def sampled_data_spectral_radius(kp, kv, ts, mu):
    """Spectral radius of the sampled-data error dynamics ``ë = -μ (kp e_k + kv ė_k)`` held over ``Ts``.

    A PD-type correction computed at ``t_k`` from the sampled error and held constant (zero-order
    hold) acts on a double integrator; over one sample ``(e, ė)`` evolve exactly as
    ``x_{k+1} = A x_k`` with::

        A = [[1 - μ kp Ts²/2,  Ts - μ kv Ts²/2],
             [-μ kp Ts,        1 - μ kv Ts   ]]

    and the loop is stable when the spectral radius of ``A`` is below 1 (at most 1 is marginal).
    ``μ`` is the gain of one modal direction of the loop: for computed torque the eigenvalues of
    ``Mθ_plant⁻¹ M̂θ`` (the plant's and the controller's actuator-space mass matrices; ``μ = 1``
    when the model is exact), for the joint PD law ``τ = -kp e - kv ė`` the eigenvalues of
    ``Mθ_plant⁻¹`` (1/(kg·m²), ``kp`` in N·m/rad). Both are real and positive (products of
    symmetric positive-definite matrices).

    With ``a = μ kp Ts²/2`` and ``b = μ kv Ts``, ``trace A = 2 - a - b`` and ``det A = 1 + a - b``;
    the loop is stable exactly when ``a < b < 2``. Every argument broadcasts (NumPy arrays), so a
    whole path's ``μ`` is one call; returns a float for scalar arguments.

    >>> round(float(sampled_data_spectral_radius(1000.0, 63.2, 1e-3, 1.0)), 4)
    0.9719
    >>> bool(sampled_data_spectral_radius(1e12, 2e6, 1e-3, 1.0) > 1)
    True
    """
    kp, kv, ts, mu = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (kp, kv, ts, mu)))
    # gains near the float range (kp = 1e300) overflow here: the radius is then inf (or NaN), which every caller
    # reads as unstable and says so in its own words; NumPy's warnings would only come first, with other words
    with np.errstate(over="ignore", invalid="ignore"):
        a = 0.5 * mu * kp * ts * ts
        b = mu * kv * ts
        half_trace = 1.0 - 0.5 * (a + b)
        det = 1.0 + a - b
        disc = half_trace * half_trace - det
        # real eigenvalues: half_trace ± √disc; a complex pair: both of modulus √det
        rho = np.where(disc >= 0.0, np.abs(half_trace) + np.sqrt(np.abs(disc)), np.sqrt(np.abs(det)))
    return float(rho) if rho.ndim == 0 else rho


def _stable(kp, kv, ts, mu) -> bool:
    return bool(np.max(sampled_data_spectral_radius(kp, kv, ts, mu)) <= 1.0 + STABILITY_TOLERANCE)


def _largest_stable(stable, start: float) -> float | None:
    """The largest ``x > 0`` with ``stable(x)``, when the stable set is ``(0, x*]``; bisection in ``log x``.

    ``None`` when even a tiny ``x`` is unstable, ``inf`` when no ``x`` is.
    """
    lo, hi = start, start
    while not stable(lo):
        lo /= 16.0
        if lo < start * 1e-30:
            return None
    while stable(hi):
        hi *= 16.0
        if hi > start * 1e30:
            return math.inf
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if not lo < mid < hi:
            break
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def largest_stable_kp(ts: float, mu) -> float | None:
    """The largest ``kp``, with critical damping ``kv = 2√kp``, for which the sampled-data loop of
    :func:`sampled_data_spectral_radius` is stable for every modal gain in ``mu`` at sample time ``ts``.

    >>> round(largest_stable_kp(1e-3, [0.5, 1.0]))
    1000000
    """
    mu = np.asarray(mu, dtype=float)
    return _largest_stable(lambda kp: _stable(kp, 2.0 * math.sqrt(kp), ts, mu), 1.0 / ts**2)


def largest_stable_sample_time(kp: float, kv: float, mu) -> float | None:
    """The largest sample time for which the gains ``kp, kv`` give a stable sampled-data loop for every
    modal gain in ``mu`` (:func:`sampled_data_spectral_radius`); ``None`` when none does (``kv = 0``).

    >>> round(largest_stable_sample_time(1e6, 2e3, 1.0), 9)
    0.001
    """
    if kv <= 0.0 < kp:  # det A = 1 + μ kp Ts²/2 > 1 at every Ts: a P law needs damping
        return None
    mu = np.asarray(mu, dtype=float)
    return _largest_stable(lambda ts: _stable(kp, kv, ts, mu), 1e-3)
