"""pkmlab's preset mechanisms, written as descriptions (:mod:`pkmlab.description.mechanism`).

* ``paper`` — the planar 3-RRR of Nasa & Bandyopadhyay (the paper's table, equilateral base of
  side 0.52 m and platform of side 0.125 m, tracked point at the platform's centroid);
* ``five_bar`` — a planar 2-RRRRR (five-bar) with a payload at its end point;
* ``3rpr`` — a 3-RPR with telescopic actuated legs on the paper's base and platform (similar
  triangles: singular wherever the platform is at alpha = 0 or pi);
* ``3prr`` — a 3-PRR whose actuated sliders run along the sides of the paper's base;
* ``delta`` — the Delta robot (spatial, three translations, with gravity), described as three
  R*US legs on a translating platform (:mod:`pkmlab.description.spatial`);
* ``stewart`` — a Stewart–Gough platform (hexapod): six UP*S legs, each a cylinder and a rod, a
  platform with six degrees of freedom, against gravity.

Every number is a parameter of the description: write a preset out with
:func:`~pkmlab.description.files.mechanism_to_toml`, edit it, and load it back.
"""

from __future__ import annotations

import math

from .mechanism import Body, Joint, Leg, Mechanism, Platform
from .spatial import SpatialBody, SpatialJoint, SpatialLeg, SpatialMechanism, SpatialPlatform

#: The paper's base side and platform side (m).
BASE_SIDE = 0.52
PLATFORM_SIDE = 0.125


def equilateral_base(side: float = BASE_SIDE) -> tuple[tuple[float, float], ...]:
    """``b1 = (0, 0)``, ``b2 = (side, 0)``, ``b3 = (side/2, √3/2·side)``."""
    return ((0.0, 0.0), (side, 0.0), (side / 2, math.sqrt(3) / 2 * side))


def equilateral_platform(side: float = PLATFORM_SIDE, mass: float = 0.234, inertia: float = 0.305e-3) -> Platform:
    """The paper's platform: vertices ``p1, p2, p3`` counter-clockwise, frame origin at the centroid,
    x axis along ``p1 → p2`` (so that ``p2 = p1 + side·u(alpha)``); mass centre at the centroid."""
    h = side / (2 * math.sqrt(3))
    return Platform("rigid", ((-side / 2, -h), (side / 2, -h), (0.0, 2 * h)), mass, (0.0, 0.0), inertia)


def _link(length: float, mass: float, inertia: float) -> Body:
    """A uniform link: tip at ``length`` along it, mass centre at its middle."""
    return Body((length, 0.0), mass, (length / 2, 0.0), inertia)


def paper() -> Mechanism:
    """The paper's 3-RRR: actuated links l = 0.25 m (0.468 kg, 2.438e-3 kg m²), passive links
    r = 0.1667 m (0.312 kg, 0.722e-3 kg m²), platform 0.234 kg, 0.305e-3 kg m²."""
    legs = tuple(Leg(b, (Joint("R", True), Joint("R"), Joint("R")),
                     (_link(0.25, 0.468, 2.438e-3), _link(0.1667, 0.312, 0.722e-3)))
                 for b in equilateral_base())
    return Mechanism("paper", legs, equilateral_platform())


def five_bar() -> Mechanism:
    """Five-bar: base joints (∓0.10, 0), actuated links 0.25 m (0.30 kg, 1.6e-3 kg m²), distal links
    0.30 m (0.20 kg, 1.5e-3 kg m²) meeting at the end point, which carries a 0.10 kg payload."""
    legs = tuple(Leg(base, (Joint("R", True), Joint("R"), Joint("R")),
                     (_link(0.25, 0.30, 1.6e-3), _link(0.30, 0.20, 1.5e-3)))
                 for base in ((-0.10, 0.0), (0.10, 0.0)))
    return Mechanism("five_bar", legs, Platform("point", (), 0.10))


def rpr3() -> Mechanism:
    """3-RPR: a cylinder turning about ``b_i`` (0.50 kg, mass centre 0.08 m out, 1.5e-3 kg m²) and a rod
    sliding in it to ``p_i`` (0.25 kg, mass centre 0.06 m from ``p_i`` towards ``b_i``, 0.6e-3 kg m²);
    actuated leg lengths from 0.10 to 0.45 m; the paper's base and platform."""
    legs = tuple(Leg(b, (Joint("R"), Joint("P", True), Joint("R")),
                     (Body((0.0, 0.0), 0.50, (0.08, 0.0), 1.5e-3), Body((0.0, 0.0), 0.25, (-0.06, 0.0), 0.6e-3)),
                     stroke=(0.10, 0.45))
                 for b in equilateral_base())
    return Mechanism("3rpr", legs, equilateral_platform())


def prr3() -> Mechanism:
    """3-PRR: sliders (0.60 kg) on rails along ``b1→b2``, ``b2→b3``, ``b3→b1`` (strokes 0 to 0.52 m),
    passive links 0.25 m (0.25 kg, 0.8e-3 kg m²) to the paper's platform."""
    legs = tuple(Leg(b, (Joint("P", True, axis=beta), Joint("R"), Joint("R")),
                     (Body((0.0, 0.0), 0.60, (0.0, 0.0), 0.0), _link(0.25, 0.25, 0.8e-3)),
                     stroke=(0.0, BASE_SIDE))
                 for b, beta in zip(equilateral_base(), (0.0, 2 * math.pi / 3, 4 * math.pi / 3), strict=True))
    return Mechanism("3prr", legs, equilateral_platform())


def delta(base_radius: float = 0.20, arm: float = 0.35, forearm: float = 0.80,
          platform_radius: float = 0.05) -> SpatialMechanism:
    """The Delta robot: arms at azimuths ``γ_i = (i - 1)·2π/3`` (``w_i = (cos γ_i, sin γ_i, 0)``), actuated
    revolutes at ``B_i = R_b w_i`` about ``e_z × w_i``, so that the arm angle ``θ_i`` turns the arm below the
    horizontal: elbow ``E_i = B_i + L_a (cos θ_i w_i - sin θ_i e_z)``. Upper arm 0.40 kg, mass centre at
    ``L_a/2``, 0.0183 kg m² about its joint axis (arm and the motor's reflected rotor). Each forearm, a
    parallelogram of two thin uniform rods (0.10 kg together) whose ends translate with ``E_i`` and
    ``P_i = P + R_p w_i``, is one body from a universal joint at the elbow to a spherical joint on the
    platform: mass centre at its middle, inertia ``(m L_b²/12)`` across it and none along it, which
    gives exactly the rods' kinetic energy ``(m/6)(|Ė_i|² + Ė_i·Ṗ_i + |Ṗ_i|²)``. Platform and payload
    0.30 kg, translating. Gravity 9.81 m/s² along -z; the base plane is z = 0."""
    arm_mass, arm_inertia_at_axis, forearm_mass = 0.40, 0.0183, 0.10
    # the arm's inertia about its mass centre, about the joint axis (parallel axes: minus m (L_a/2)²)
    arm_inertia = arm_inertia_at_axis - arm_mass * (arm / 2) ** 2
    rod = forearm_mass * forearm**2 / 12
    legs = []
    for i in range(3):
        gamma = i * 2 * math.pi / 3
        w = (math.cos(gamma), math.sin(gamma), 0.0)
        axis = (-math.sin(gamma), math.cos(gamma), 0.0)  # e_z x w: positive turns take the arm down
        # a rod along w: no inertia along it, the same across it (only the part about the axis moves it)
        arm_tensor = tuple(tuple(arm_inertia * ((r == c) - w[r] * w[c]) for c in range(3)) for r in range(3))
        legs.append(SpatialLeg(
            tuple(base_radius * c for c in w),
            (SpatialJoint("R", True, (axis,)), SpatialJoint("U", False, (axis, w)), SpatialJoint("S")),
            (SpatialBody(tuple(arm * c for c in w), arm_mass, tuple(arm / 2 * c for c in w), arm_tensor),
             # the forearm hangs along -z at zero joint angles
             SpatialBody((0.0, 0.0, -forearm), forearm_mass, (0.0, 0.0, -forearm / 2),
                         ((rod, 0.0, 0.0), (0.0, rod, 0.0), (0.0, 0.0, 0.0))))))
    attachments = tuple((platform_radius * math.cos(g), platform_radius * math.sin(g), 0.0)
                        for g in (i * 2 * math.pi / 3 for i in range(3)))
    return SpatialMechanism("delta", tuple(legs), SpatialPlatform("translating", attachments, 0.30),
                            (0.0, 0.0, -9.81))


def stewart(base_radius: float = 0.50, platform_radius: float = 0.30, base_spread: float = 12.0,
            platform_spread: float = 48.0) -> SpatialMechanism:
    """A hexapod: base joints in pairs at azimuths ``120° k ± base_spread`` on a circle of ``base_radius`` (z = 0),
    platform joints at ``120° k ± platform_spread`` on a circle of ``platform_radius`` (platform frame).
    Each leg: a universal joint on the base (axes tangential, then radial), a cylinder (1.2 kg, mass centre
    0.2 m up the leg), an actuated prismatic joint along the leg (stroke 0.55 to 1.15 m) and a rod (0.6 kg,
    mass centre 0.25 m from the platform's spherical joint down the leg) that ends at that joint. Platform
    8 kg, mass centre 0.02 m above its frame's origin. Gravity 9.81 m/s² along -z."""
    cylinder = SpatialBody((0.0, 0.0, 0.0), 1.2, (0.0, 0.0, 0.2),
                           ((0.02, 0.0, 0.0), (0.0, 0.02, 0.0), (0.0, 0.0, 1e-3)))
    rod = SpatialBody((0.0, 0.0, 0.0), 0.6, (0.0, 0.0, -0.25),
                      ((0.012, 0.0, 0.0), (0.0, 0.012, 0.0), (0.0, 0.0, 4e-4)))
    legs, attachments = [], []
    for k in range(3):
        for side in (-1, 1):
            g = math.radians(120 * k + side * base_spread)
            tangential, radial = (-math.sin(g), math.cos(g), 0.0), (math.cos(g), math.sin(g), 0.0)
            # the leg points up (+z) at zero joint angles; the rod slides out of the cylinder along it
            legs.append(SpatialLeg((base_radius * math.cos(g), base_radius * math.sin(g), 0.0),
                                   (SpatialJoint("U", False, (tangential, radial)),
                                    SpatialJoint("P", True, ((0.0, 0.0, 1.0),)), SpatialJoint("S")),
                                   (cylinder, rod), stroke=(0.55, 1.15)))
            a = math.radians(120 * k + side * platform_spread)
            attachments.append((platform_radius * math.cos(a), platform_radius * math.sin(a), 0.0))
    platform = SpatialPlatform("rigid", tuple(attachments), 8.0, (0.0, 0.0, 0.02),
                               ((0.12, 0.0, 0.0), (0.0, 0.12, 0.0), (0.0, 0.0, 0.2)))
    return SpatialMechanism("stewart", tuple(legs), platform, (0.0, 0.0, -9.81))


#: The presets by name: the planar ones, then the spatial ones.
PLANAR_PRESETS = {"paper": paper, "five_bar": five_bar, "3rpr": rpr3, "3prr": prr3}
SPATIAL_PRESETS = {"delta": delta, "stewart": stewart}
PRESETS = {**PLANAR_PRESETS, **SPATIAL_PRESETS}


def preset(name: str) -> Mechanism | SpatialMechanism:
    """The preset ``name`` (one of :data:`PRESETS`)."""
    from ..errors import InvalidParameterError

    if not isinstance(name, str) or name not in PRESETS:
        raise InvalidParameterError(f"unknown mechanism preset {name!r}: choose one of {', '.join(PRESETS)}")
    return PRESETS[name]()
