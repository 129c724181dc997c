"""The immutable description of a planar 3-RRR parallel manipulator (paper §2.1, conventions §1).

A :class:`Planar3RRR` is a *model* in the MuJoCo/Pinocchio sense: architecture and inertia
parameters only, validated once, never mutated. Configurations ``q`` are plain NumPy arrays
kept apart from it.

Conventions (conventions §1):

* all angles are absolute, measured from the base x axis, counter-clockwise;
* ``q = (θ1, θ2, θ3, φ1, φ2, φ3, α)``: the three actuated angles first, then the passive
  ones (the paper's ``φ = (φ1, φ2, φ3, α)``);
* leg ``i``: elbow ``e_i = b_i + l_i·u(θ_i)``, platform vertex ``p_i = e_i + r_i·u(φ_i)``,
  ``u(x) = (cos x, sin x)``;
* platform: ``p_i = p1 + R(α)·P_i`` with ``P_i`` the vertices in the platform frame
  (origin at ``p1``, x axis along ``p1 → p2``); for the paper's equilateral platform of side
  ``a``, ``P2 = (a, 0)``, ``P3 = a·u(π/3)``;
* the platform's reference point (its "position" ``(x, y)``) is its centroid.

The model is packed into one flat ``float64`` vector (:attr:`Planar3RRR.packed`) that the
compiled kernels read through the index constants below.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .._validate import real_array
from ..description import _rrr3_layout as layout  # the packed parameters' layout the compiled kernels read
from ..errors import InvalidParameterError, shown

#: The longest platform side accepted (m): far beyond any machine, far below the float range.
MAX_LENGTH = 1e100

#: Working modes of inverse kinematics, in the order pkmlab reports them (conventions §3).
WORKING_MODES = np.array(
    [(s1, s2, s3) for s1 in (1, -1) for s2 in (1, -1) for s3 in (1, -1)], dtype=np.int64
)
WORKING_MODES.setflags(write=False)

COORDINATE_NAMES = ("theta1", "theta2", "theta3", "phi1", "phi2", "phi3", "alpha")


def _per_leg(name: str, value) -> np.ndarray:
    arr = real_array(name, value, "a number or a list of 3 numbers")
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,):
        raise InvalidParameterError(f"{name} must be a number or a list of 3 numbers (one per leg)")
    return arr


def _float_array(label: str, value) -> np.ndarray:
    """``value`` as a float array; a non-numeric or ragged value is an :class:`InvalidParameterError`."""
    return real_array(label, value, "numeric")


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Planar3RRR:
    """Architecture and inertia of a planar 3-RRR (one instance = one machine).

    Build it with :meth:`paper` or :meth:`from_params`; the constructor takes the arrays
    directly. Lengths in metres, masses in kg, inertias in kg·m² about each body's own mass
    centre; arrays per leg have shape ``(3,)``.

    Attributes
    ----------
    base_points : (3, 2) array
        ``b_i``, the fixed actuated joints.
    active_lengths, passive_lengths : (3,) arrays
        ``l_i`` (actuated link ``b_i e_i``) and ``r_i`` (passive link ``e_i p_i``).
    platform_side : float
        ``a``, the side of the equilateral platform ``p1 p2 p3``.
    active_masses, passive_masses : (3,) arrays; platform_mass : float
    active_inertias, passive_inertias : (3,) arrays; platform_inertia : float
    active_com, passive_com : (3, 2) arrays
        Mass centre of each link in its own frame (x along the link): ``(l_i/2, 0)`` and
        ``(r_i/2, 0)`` (the midpoints) by default.
    platform_com : (2,) array
        Platform mass centre in the platform frame; the centroid by default.

    Examples
    --------
    >>> m = Planar3RRR.paper()
    >>> float(m.platform_side), m.active_lengths.tolist()
    (0.125, [0.25, 0.25, 0.25])
    >>> Planar3RRR.from_params(l=-1.0)
    Traceback (most recent call last):
    ...
    pkmlab.errors.InvalidParameterError: l (active link length) must be positive, got l1 = -1
    """

    base_points: np.ndarray
    active_lengths: np.ndarray
    passive_lengths: np.ndarray
    platform_side: float
    active_masses: np.ndarray = field(default_factory=lambda: np.ones(3))
    passive_masses: np.ndarray = field(default_factory=lambda: np.ones(3))
    platform_mass: float = 1.0
    active_inertias: np.ndarray = field(default_factory=lambda: np.full(3, 1e-3))
    passive_inertias: np.ndarray = field(default_factory=lambda: np.full(3, 1e-3))
    platform_inertia: float = 1e-3
    active_com: np.ndarray | None = None
    passive_com: np.ndarray | None = None
    platform_com: np.ndarray | None = None

    # ---------------------------------------------------------------- construction
    def __post_init__(self):
        set_ = object.__setattr__
        base = _float_array("base_points", self.base_points)
        if base.shape != (3, 2):
            raise InvalidParameterError("base_points must be 3 points (x, y)")
        set_(self, "base_points", _frozen(base))
        for name, label in (("active_lengths", "l"), ("passive_lengths", "r"),
                            ("active_masses", "mass_l"), ("passive_masses", "mass_r"),
                            ("active_inertias", "inertia_l"), ("passive_inertias", "inertia_r")):
            set_(self, name, _frozen(_per_leg(label, getattr(self, name))))
        for name, label in (("platform_side", "a (platform side)"), ("platform_mass", "mass_a"),
                            ("platform_inertia", "inertia_a")):
            value = _float_array(label, getattr(self, name))
            if value.ndim != 0:
                raise InvalidParameterError(f"{label} must be a single number, got {shown(getattr(self, name))}")
            set_(self, name, float(value))
        if self.active_com is None:
            set_(self, "active_com", np.column_stack([self.active_lengths / 2, np.zeros(3)]))
        if self.passive_com is None:
            set_(self, "passive_com", np.column_stack([self.passive_lengths / 2, np.zeros(3)]))
        if self.platform_com is None:
            set_(self, "platform_com", self.platform_vertices.mean(axis=0))
        for name, shape in (("active_com", (3, 2)), ("passive_com", (3, 2)), ("platform_com", (2,))):
            arr = _float_array(name, getattr(self, name))
            if arr.shape != shape:
                raise InvalidParameterError(f"{name} must have shape {shape}")
            set_(self, name, _frozen(arr))
        self._validate()

    @classmethod
    def paper(cls) -> Planar3RRR:
        """The manipulator of the paper's section 5 with conventions §1's choices (the ``paper`` preset)."""
        return cls.from_params()

    @classmethod
    def from_params(
        cls,
        *,
        b: float | None = None,
        l=0.25,
        r=0.1667,
        a: float = 0.125,
        mass_l=0.468,
        mass_r=0.312,
        mass_a: float = 0.234,
        inertia_l=2.438e-3,
        inertia_r=0.722e-3,
        inertia_a: float = 0.305e-3,
        base_points=None,
    ) -> Planar3RRR:
        """Build a 3-RRR from the paper's parameter names (defaults: the ``paper`` preset).

        ``b`` (default 0.52) is the side of the equilateral base (``b1 = (0, 0)``, ``b2 = (b, 0)``,
        ``b3 = (b/2, √3/2·b)``), or ``base_points`` gives the three points explicitly — not both,
        since one would be ignored. ``l, r`` and the per-link masses/inertias accept one number
        or one per leg.
        """
        if b is not None and base_points is not None:
            raise InvalidParameterError("give either b (an equilateral base) or base_points, not both")
        if base_points is None:
            b = 0.52 if b is None else b
            b = _check_number("b", b, positive=True)
            base_points = [(0.0, 0.0), (b, 0.0), (b / 2, math.sqrt(3) / 2 * b)]
        # the platform's vertices and centroid are sums of multiples of a: a side near the float range
        # would overflow there and be reported under their names instead of its own
        if _check_number("a (platform side)", a, positive=True) > MAX_LENGTH:
            raise InvalidParameterError(f"a (platform side) must be at most {MAX_LENGTH:g} m, got {float(a):g}")
        return cls(
            base_points=base_points,
            active_lengths=l,
            passive_lengths=r,
            platform_side=a,
            active_masses=mass_l,
            passive_masses=mass_r,
            platform_mass=mass_a,
            active_inertias=inertia_l,
            passive_inertias=inertia_r,
            platform_inertia=inertia_a,
        )

    def replace(self, **changes) -> Planar3RRR:
        """A copy with some attributes changed (validated again).

        Mass centres given as defaults (link midpoints, platform centroid) follow changed
        lengths; explicitly set ones are kept.
        """
        current = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for name in changes:
            if name not in current:
                raise InvalidParameterError(f"{name} is not an attribute of Planar3RRR "
                                            f"(attributes: {', '.join(current)})")
        defaults = Planar3RRR(self.base_points, self.active_lengths, self.passive_lengths, self.platform_side)
        for name in ("active_com", "passive_com", "platform_com"):
            if name not in changes and np.allclose(current[name], getattr(defaults, name)):
                current[name] = None
        current.update(changes)
        return Planar3RRR(**current)

    # ---------------------------------------------------------------- derived values
    @property
    def platform_vertices(self) -> np.ndarray:
        """``P_i`` (3, 2): the platform's vertices in the platform frame (``P1`` is the origin)."""
        a = self.platform_side
        return np.array([(0.0, 0.0), (a, 0.0), (a / 2, a * math.sqrt(3) / 2)])

    @property
    def reference_point(self) -> np.ndarray:
        """The platform point whose position is reported as ``(x, y)``: its centroid (conventions §1)."""
        return self.platform_vertices.mean(axis=0)

    @cached_property
    def packed(self) -> np.ndarray:
        """The flat, read-only parameter vector the compiled kernels read (:mod:`pkmlab.description._rrr3_layout`)."""
        p = np.zeros(layout.N_PACKED)
        p[layout.BASE:layout.BASE + 6] = self.base_points.ravel()
        p[layout.ACTIVE_LENGTH:layout.ACTIVE_LENGTH + 3] = self.active_lengths
        p[layout.PASSIVE_LENGTH:layout.PASSIVE_LENGTH + 3] = self.passive_lengths
        p[layout.PLATFORM:layout.PLATFORM + 4] = self.platform_vertices[1:].ravel()
        p[layout.REFERENCE:layout.REFERENCE + 2] = self.reference_point
        p[layout.ACTIVE_MASS:layout.ACTIVE_MASS + 3] = self.active_masses
        p[layout.PASSIVE_MASS:layout.PASSIVE_MASS + 3] = self.passive_masses
        p[layout.PLATFORM_MASS] = self.platform_mass
        p[layout.ACTIVE_INERTIA:layout.ACTIVE_INERTIA + 3] = self.active_inertias
        p[layout.PASSIVE_INERTIA:layout.PASSIVE_INERTIA + 3] = self.passive_inertias
        p[layout.PLATFORM_INERTIA] = self.platform_inertia
        p[layout.ACTIVE_COM:layout.ACTIVE_COM + 6] = self.active_com.ravel()
        p[layout.PASSIVE_COM:layout.PASSIVE_COM + 6] = self.passive_com.ravel()
        p[layout.PLATFORM_COM:layout.PLATFORM_COM + 2] = self.platform_com
        p.setflags(write=False)
        return p

    def to_mechanism(self, name: str = "paper"):
        """This machine as a mechanism description (:class:`~pkmlab.description.mechanism.Mechanism`), the
        same numbers in the description's conventions: the platform frame's origin moved from ``P1`` to the
        centroid (the tracked point), the x axis kept along ``P1 → P2``. What the generic pipeline
        (:class:`~pkmlab.model.mechanism_model.MechanismModel`) models and simulates this machine from."""
        from ..description.mechanism import Body, Joint, Leg, Mechanism, Platform

        legs = tuple(
            Leg(tuple(self.base_points[i]), (Joint("R", True), Joint("R"), Joint("R")),
                (Body((self.active_lengths[i], 0.0), self.active_masses[i], tuple(self.active_com[i]),
                      self.active_inertias[i]),
                 Body((self.passive_lengths[i], 0.0), self.passive_masses[i], tuple(self.passive_com[i]),
                      self.passive_inertias[i])))
            for i in range(3))
        c = self.reference_point
        platform = Platform("rigid", tuple(tuple(v - c) for v in self.platform_vertices), self.platform_mass,
                            tuple(self.platform_com - c), self.platform_inertia)
        return Mechanism(name, legs, platform)

    def as_dict(self) -> dict:
        """Plain-Python description (lists and floats), e.g. for JSON output."""
        return {f.name: np.asarray(getattr(self, f.name)).tolist() for f in dataclasses.fields(self)}

    def __eq__(self, other) -> bool:
        return isinstance(other, Planar3RRR) and np.array_equal(self.packed, other.packed)

    def __hash__(self) -> int:
        # ``+ 0.0`` turns -0.0 into 0.0: equal models (np.array_equal) must hash equal.
        return hash((self.packed + 0.0).tobytes())

    def __repr__(self) -> str:
        return (
            f"Planar3RRR(base_points={self.base_points.tolist()}, l={self.active_lengths.tolist()}, "
            f"r={self.passive_lengths.tolist()}, a={self.platform_side})"
        )

    # ---------------------------------------------------------------- validation
    def _validate(self) -> None:
        _check_array("l (active link length)", "l", self.active_lengths, positive=True)
        _check_array("r (passive link length)", "r", self.passive_lengths, positive=True)
        _check_number("a (platform side)", self.platform_side, positive=True)
        for i, point in enumerate(self.base_points):
            if not np.all(np.isfinite(point)):
                raise InvalidParameterError(f"base point b{i + 1} must be finite, got {point.tolist()}")
        _check_array("mass_l", "mass_l", self.active_masses, positive=True)
        _check_array("mass_r", "mass_r", self.passive_masses, positive=True)
        _check_number("mass_a", self.platform_mass, positive=True)
        _check_array("inertia_l", "inertia_l", self.active_inertias, positive=True)
        _check_array("inertia_r", "inertia_r", self.passive_inertias, positive=True)
        _check_number("inertia_a", self.platform_inertia, positive=True)
        for name in ("active_com", "passive_com", "platform_com"):
            _check_array(name, name, np.ravel(getattr(self, name)), positive=False)
        b = self.base_points
        (ux, uy), (vx, vy) = b[1] - b[0], b[2] - b[0]
        area = 0.5 * abs(ux * vy - uy * vx)
        if area <= 1e-12 * max(1.0, np.ptp(b) ** 2):
            raise InvalidParameterError("base points b1, b2, b3 are collinear: the base must be a triangle")
        if not _can_be_assembled(self):
            raise InvalidParameterError(
                f"the platform cannot be assembled anywhere: no pose puts all three vertices within "
                f"reach of their legs (a = {self.platform_side:g}, l = {self.active_lengths.tolist()}, "
                f"r = {self.passive_lengths.tolist()}); change a, l, r or the base"
            )


def _check_number(label: str, value, positive: bool) -> float:
    try:  # "0.52" or True are slips, not numbers, though float() takes them
        v = None if isinstance(value, (str, bytes, bool, np.bool_)) else float(value)
    except (TypeError, ValueError, OverflowError):
        v = None
    if v is None:
        raise InvalidParameterError(f"{label} must be a number, got {shown(value)}")
    if not math.isfinite(v):
        raise InvalidParameterError(f"{label} must be finite, got {v}")
    if positive and v <= 0:
        raise InvalidParameterError(f"{label} must be positive, got {v:g}")
    return v


def _check_array(label: str, short: str, values: np.ndarray, positive: bool) -> None:
    for i, v in enumerate(values):
        if not math.isfinite(v):
            raise InvalidParameterError(f"{label} must be finite, got {short}{i + 1} = {v}")
        if positive and v <= 0:
            raise InvalidParameterError(f"{label} must be positive, got {short}{i + 1} = {v:g}")


def _assembly_margin(model: Planar3RRR, p1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Smallest distance (m) by which any vertex is inside its leg's reachable annulus.

    Positive where every leg reaches: vertex ``p_i`` lies within ``[|l_i - r_i|, l_i + r_i]``
    of ``b_i``. Broadcasts over ``p1`` (..., 2) and ``alpha`` (...).
    """
    c, s = np.cos(alpha), np.sin(alpha)
    margin = np.full(np.broadcast_shapes(p1.shape[:-1], np.shape(alpha)), np.inf)
    for i, (vx, vy) in enumerate(model.platform_vertices):
        px = p1[..., 0] + c * vx - s * vy - model.base_points[i, 0]
        py = p1[..., 1] + s * vx + c * vy - model.base_points[i, 1]
        rho = np.hypot(px, py)
        lo = abs(model.active_lengths[i] - model.passive_lengths[i])
        hi = model.active_lengths[i] + model.passive_lengths[i]
        margin = np.minimum(margin, np.minimum(rho - lo, hi - rho))
    return margin


def _can_be_assembled(model: Planar3RRR) -> bool:
    """Whether some pose lets all three legs reach their vertices (coarse, then fine search)."""
    reach = model.active_lengths + model.passive_lengths
    lo = (model.base_points - reach[:, None]).min(axis=0)
    hi = (model.base_points + reach[:, None]).max(axis=0)
    for n_xy, n_alpha in ((24, 24), (90, 120)):
        gx = np.linspace(lo[0], hi[0], n_xy)
        gy = np.linspace(lo[1], hi[1], n_xy)
        ga = np.linspace(-np.pi, np.pi, n_alpha, endpoint=False)
        p1 = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1)[:, :, None, :]
        margin = _assembly_margin(model, p1, ga[None, None, :])
        if margin.max() >= 0:
            return True
    # Refine the best grid point: the feasible set may be thinner than the grid spacing.
    from scipy.optimize import minimize

    best = np.unravel_index(np.argmax(margin), margin.shape)
    x0 = np.array([gx[best[0]], gy[best[1]], ga[best[2]]])
    res = minimize(lambda z: -_assembly_margin(model, z[:2], z[2]), x0, method="Nelder-Mead",
                   options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
    return -res.fun >= -1e-12
