"""pkmlab's preset mechanisms, written as descriptions (:mod:`pkmlab.mechanisms.description`).

* ``paper`` — the planar 3-RRR of Nasa & Bandyopadhyay (the paper's table, equilateral base of
  side 0.52 m and platform of side 0.125 m, tracked point at the platform's centroid);
* ``five_bar`` — a planar 2-RRRRR (five-bar) with a payload at its end point;
* ``3rpr`` — a 3-RPR with telescopic actuated legs on the paper's base and platform (similar
  triangles: singular wherever the platform is at alpha = 0 or pi);
* ``3prr`` — a 3-PRR whose actuated sliders run along the sides of the paper's base.

Every number is a parameter of the description: write a preset out with
:func:`~pkmlab.mechanisms.description.mechanism_to_toml`, edit it, and load it back.
"""

from __future__ import annotations

import math

from .description import Body, Joint, Leg, Mechanism, Platform

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


#: The presets by name.
PRESETS = {"paper": paper, "five_bar": five_bar, "3rpr": rpr3, "3prr": prr3}


def preset(name: str) -> Mechanism:
    """The preset ``name`` (one of :data:`PRESETS`)."""
    from ..errors import InvalidParameterError

    if not isinstance(name, str) or name not in PRESETS:
        raise InvalidParameterError(f"unknown mechanism preset {name!r}: choose one of {', '.join(PRESETS)}")
    return PRESETS[name]()
