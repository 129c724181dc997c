"""What makes a plant real: its drives and the sensors the controller reads, declared per actuator, every one
optional (a scenario without them runs the ideal plant of the paper, exactly as before).

**Drives** (:class:`Drives`). Each actuator is driven through a gear of ratio ``N`` (joint rate = motor rate / N):
the motor's rotor inertia ``I_m`` is felt at the joint as the armature ``N² I_m``; the motor's torque limit
``τ_m,max`` limits the joint's effort to ``N τ_m,max`` (the command is saturated there); friction is given at
the joint, viscous ``fv θ̇`` and Coulomb ``fc φ(θ̇)``. The Coulomb law is smooth, ``φ = tanh(θ̇ / v_c)`` with
``coulomb_rate = v_c`` > 0 (a fixed-step integrator needs it: the exact law switches within a step), or exact,
``φ = sign(θ̇)`` (zero at rest, no stiction) with ``coulomb_rate = 0``, or stick–slip (``stick_slip = True``,
Karnopp's model): outside a window ``|θ̇| < v_c`` the friction is ``fc sign(θ̇)``; inside it an actuator sticks —
its acceleration is zero, the friction whatever holds it — as long as that friction stays within ``fc``, and
slips when the efforts on it exceed that (the actuators are solved together: one sticking changes what the
others feel). A rate below the window counts as rest, so the window is the model's resolution of rest. The
effort the drive applies may carry
white noise (``effort_noise``, its standard deviation), drawn once per sample and held with the command. The
plant's actuator-space dynamics become

    ``(Mθ + N² I_m) θ̈ + cθ + gθ + fv θ̇ + fc φ(θ̇) = sat(τ) + ν``

— the form whose parameters :func:`pkmlab.identify` with ``drives=True`` estimates (``Ia = N² I_m``).

**Sensors** (:class:`Sensors`). The controller sees only measurements: each actuator's value read by an encoder
of ``resolution`` (at the joint, rad or m: a motor encoder of ``c`` counts per turn behind a gear ``N`` reads
``2π / (c N)``), rounded to it, after white noise of standard deviation ``noise``; taken ``delay`` samples
earlier; its rate either the encoder's values differenced sample to sample (``rates = "difference"``, what a
drive without a tachometer has: half a sample late), their second-order backward difference ``(3 θ_k -
4 θ_k-1 + θ_k-2) / (2 Ts)`` (``"backward2"``: no lag to first order, 1.8 times the difference's quantisation
noise), or the plant's exact rate (``"exact"``: a tachometer). The measurements are recorded with
the run (``theta_measured``, the ``theta<j>_m`` columns of ``run.csv``) — what a real machine logs.

Noise is drawn from NumPy's generator seeded by the scenario's ``seed``: the efforts' from ``(seed, 0)``, the
sensors' from ``(seed, 1)``, a row per sample, so that a run is reproduced exactly by its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import as_choice, as_count, as_real
from ..errors import InvalidParameterError, shown

__all__ = ["Drives", "Sensors", "SENSED_RATES"]

#: How :class:`Sensors` give the actuators' rates.
SENSED_RATES = ("difference", "backward2", "exact")


def _per_actuator(name: str, value, sign: str, allow_inf: bool = False) -> tuple[float, ...] | float:
    """One number, or a tuple of numbers, checked (each ``sign``; ``inf`` allowed for a limit)."""
    if isinstance(value, list | tuple | np.ndarray):
        arr = list(np.ravel(value)) if isinstance(value, np.ndarray) else list(value)
        if not arr:
            raise InvalidParameterError(f"{name} must be a number or one per actuator, got {shown(value)}")
        return tuple(_one(f"{name}[{i}]", v, sign, allow_inf) for i, v in enumerate(arr))
    return _one(name, value, sign, allow_inf)


def _one(name: str, value, sign: str, allow_inf: bool) -> float:
    if allow_inf and isinstance(value, float | int) and not isinstance(value, bool) and value == math.inf:
        return math.inf
    return as_real(name, value, sign, bounded=True)


def _column(name: str, value, n: int) -> np.ndarray:
    if isinstance(value, tuple):
        if len(value) != n:
            raise InvalidParameterError(f"{name} must be one number or {n}, one per actuator, got {len(value)}")
        return np.array(value, dtype=float)
    return np.full(n, float(value))


@dataclass(frozen=True)
class Drives:
    """The plant's drives (the module's text): each field one number for every actuator, or one per actuator.

    Attributes
    ----------
    gear_ratio : float or tuple
        ``N``, joint rate = motor rate / N (1: a direct drive).
    armature : float or tuple
        The motor's rotor inertia ``I_m`` (kg m², or kg for a linear motor), felt as ``N² I_m`` at the joint.
    viscous : float or tuple
        ``fv`` at the joint (N m s/rad or N s/m).
    coulomb : float or tuple
        ``fc`` at the joint (N m or N).
    coulomb_rate : float
        ``v_c`` of the smooth Coulomb law (rad/s or m/s); 0 for the exact ``sign(θ̇)``; with ``stick_slip``,
        Karnopp's window (> 0).
    effort_limit : float or tuple
        The motor's largest torque (N m or N; ``inf``: none); the joint's is ``N`` times it.
    effort_noise : float or tuple
        The standard deviation of the applied effort's white noise at the joint (N m or N).
    stick_slip : bool
        Stick–slip Coulomb friction (Karnopp's model) instead of the smooth or signed law.
    """

    gear_ratio: float | tuple = 1.0
    armature: float | tuple = 0.0
    viscous: float | tuple = 0.0
    coulomb: float | tuple = 0.0
    coulomb_rate: float = 1e-3
    effort_limit: float | tuple = math.inf
    effort_noise: float | tuple = 0.0
    stick_slip: bool = False

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "gear_ratio", _per_actuator("gear_ratio", self.gear_ratio, "positive"))
        for name in ("armature", "viscous", "coulomb", "effort_noise"):
            set_(self, name, _per_actuator(name, getattr(self, name), "non-negative"))
        set_(self, "coulomb_rate", as_real("coulomb_rate", self.coulomb_rate, "non-negative"))
        set_(self, "effort_limit", _per_actuator("effort_limit", self.effort_limit, "positive", allow_inf=True))
        if not isinstance(self.stick_slip, (bool, np.bool_)):
            raise InvalidParameterError(f"stick_slip must be true or false, got {shown(self.stick_slip)}")
        set_(self, "stick_slip", bool(self.stick_slip))
        if self.stick_slip and not self.coulomb_rate > 0:
            raise InvalidParameterError("stick_slip friction needs coulomb_rate > 0: the window of rates that count "
                                        "as rest (Karnopp's model)")

    @classmethod
    def from_estimate(cls, estimate, n: int, *, coulomb_rate: float = 1e-3, stick_slip: bool = False) -> Drives:
        """The drives of an identified machine: each actuator's ``drive<j>.Ia``, ``.fv`` and ``.fc`` of
        ``estimate`` (a :class:`~pkmlab.algorithms.consistency.ConsistentEstimate` of an identification with
        drives), at the joint (``gear_ratio = 1``), with the friction law it was identified with — computed
        torque's model of them (``Scenario(controller_drives=...)``).

        Parameters
        ----------
        estimate : ConsistentEstimate
            Anything with ``value(name)`` of those names.
        n : int
            The number of actuators.
        coulomb_rate, stick_slip :
            The Coulomb law (as :class:`Drives`'; ``coulomb_rate`` the one identified with).
        """
        def column(name: str) -> tuple[float, ...]:
            return tuple(max(float(estimate.value(f"drive{j + 1}.{name}")), 0.0) for j in range(n))

        return cls(armature=column("Ia"), viscous=column("fv"), coulomb=column("fc"), coulomb_rate=coulomb_rate,
                   stick_slip=stick_slip)

    def table(self, n: int) -> np.ndarray:
        """The compiled loop's drive rows (n, 6) at the joint: reflected armature, viscous, Coulomb, its rate,
        effort limit, stick–slip (1) or not (0)."""
        ratio = _column("gear_ratio", self.gear_ratio, n)
        columns = [ratio**2 * _column("armature", self.armature, n), _column("viscous", self.viscous, n),
                   _column("coulomb", self.coulomb, n), np.full(n, self.coulomb_rate),
                   ratio * _column("effort_limit", self.effort_limit, n), np.full(n, float(self.stick_slip))]
        return np.ascontiguousarray(np.stack(columns, axis=1))

    def noise_levels(self, n: int) -> np.ndarray:
        return _column("effort_noise", self.effort_noise, n)

    def reflected_armature(self, n: int) -> np.ndarray:
        """``N² I_m`` per actuator (n,): the armature the identification sees."""
        return self.table(n)[:, 0].copy()


@dataclass(frozen=True)
class Sensors:
    """What the controller measures (the module's text).

    Attributes
    ----------
    resolution : float or tuple
        The encoder's step at the joint (rad or m); 0: not quantised.
    noise : float or tuple
        The standard deviation of the measured values' white noise (rad or m).
    delay : int
        Samples between a measurement and the effort computed from it.
    rates : {"difference", "backward2", "exact"}
        The rates the controller uses: the measured values differenced, their second-order backward difference,
        or the plant's own.
    """

    resolution: float | tuple = 0.0
    noise: float | tuple = 0.0
    delay: int = 0
    rates: str = "difference"

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "resolution", _per_actuator("resolution", self.resolution, "non-negative"))
        set_(self, "noise", _per_actuator("noise", self.noise, "non-negative"))
        set_(self, "delay", as_count("delay", self.delay, 0, 1000))
        set_(self, "rates", as_choice("rates", self.rates, SENSED_RATES))

    def resolutions(self, n: int) -> np.ndarray:
        return _column("resolution", self.resolution, n)

    def noise_levels(self, n: int) -> np.ndarray:
        return _column("noise", self.noise, n)


def check_sizes(drives: Drives | None, sensors: Sensors | None, n: int) -> None:
    """Every per-actuator field of ``drives`` and ``sensors`` of one number or ``n`` (raises naming the field)."""
    if drives is not None:
        drives.table(n)
        drives.noise_levels(n)
    if sensors is not None:
        sensors.resolutions(n)
        sensors.noise_levels(n)


def noise_rows(levels: np.ndarray, count: int, seed: int, stream: int) -> np.ndarray:
    """White noise (count, n) of standard deviations ``levels`` (n,), from the generator ``(seed, stream)``; no rows
    when every level is zero."""
    if not np.any(levels > 0):
        return np.zeros((0, levels.size))
    rng = np.random.default_rng([seed, stream])
    return np.ascontiguousarray(rng.standard_normal((count, levels.size)) * levels)
