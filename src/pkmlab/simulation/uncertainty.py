"""Parameter uncertainty: plants drawn around a model, one factor per body and quantity.

An uncertainty study asks how a controller designed on a model fares on the machines that model
may stand for. Every body of the plant — each link of each leg, and the platform — gets its own
factor for each uncertain quantity, drawn uniformly within the given bounds:

* ``mass``: the body's mass;
* ``length``: the body's lengths (its tip and mass centre; the platform's attachment points and mass
  centre). Base points, rail directions and actuator strokes are the machine's frame: unchanged;
* ``inertia``: the body's moment (planar) or tensor (spatial) of inertia about its mass centre.

The factors are named ``leg{i}.body{j}.{quantity}`` and ``platform.{quantity}`` (legs and bodies
counted from 1, bodies from the base) for every mechanism, the paper's 3-RRR included (its body 1
is the actuated link, body 2 the passive one, the platform's length the size of its triangle). Draw ``k`` of a
study seeded ``seed`` uses its own generator, ``numpy.random.default_rng([seed, k])``: a draw is the
same whatever other draws are made, in whatever order or process — what makes a study
reproducible bit for bit however it is split into chunks.

>>> from pkmlab import load
>>> model = load("paper")
>>> names = uncertain_parameters(model, ("mass",))
>>> names[:3], len(names)
(('leg1.body1.mass', 'leg1.body2.mass', 'leg2.body1.mass'), 7)
>>> factors = draw_factors(model, {"mass": (0.85, 1.15)}, seed=1, draw=0)
>>> all(0.85 <= f <= 1.15 for f in factors.values())
True
>>> perturbed_plant(model, {"platform.mass": 1.1}).description.platform.mass == 1.1 * model.description.platform.mass
True
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._format import suggestion
from ..errors import InvalidParameterError, shown

#: The quantities an uncertainty study can draw.
QUANTITIES = ("mass", "length", "inertia")


def _bodies_per_leg(model) -> list[int]:
    return [len(leg.bodies) for leg in model.description.legs]


def uncertain_parameters(model, quantities=QUANTITIES) -> tuple[str, ...]:
    """The names of the factors of ``model`` for ``quantities``, in the order they are drawn: leg by
    leg, body by body from the base, then the platform; per body, the quantities in the order of
    :data:`QUANTITIES`."""
    ordered = [q for q in QUANTITIES if q in quantities]
    names = [f"leg{i + 1}.body{j + 1}.{q}" for i, count in enumerate(_bodies_per_leg(model)) for j in range(count)
             for q in ordered]
    return (*names, *(f"platform.{q}" for q in ordered))


def check_bounds(bounds: dict, where: str = "uncertainty") -> dict[str, tuple[float, float]]:
    """``bounds`` ({quantity: (low, high)} or {quantity: spread}, a spread ``s`` meaning ``(1 - s, 1 + s)``)
    checked and normalised: known quantities, finite positive factors, ``low <= high``."""
    if not isinstance(bounds, dict):
        raise InvalidParameterError(f"{where} must be a table of quantities ({', '.join(QUANTITIES)}), got "
                                    f"{shown(bounds, 50)}")
    out = {}
    for quantity, value in bounds.items():
        if quantity not in QUANTITIES:
            raise InvalidParameterError(f"{where}: unknown quantity '{quantity}'"
                                        f"{suggestion(str(quantity), QUANTITIES)}")
        key = f"{where}.{quantity}"
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            spread = float(value)
            if not (math.isfinite(spread) and 0.0 <= spread < 1.0):
                raise InvalidParameterError(f"{key} = {shown(value)}: a spread must be a number in [0, 1) (0.15 "
                                            "draws factors in [0.85, 1.15])")
            low, high = 1.0 - spread, 1.0 + spread
        elif (isinstance(value, (list, tuple)) and len(value) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
            low, high = float(value[0]), float(value[1])
            if not (math.isfinite(low) and math.isfinite(high) and 0.0 < low <= high):
                raise InvalidParameterError(f"{key} = {shown(list(value))}: bounds must be two finite factors "
                                            "0 < low <= high, e.g. [0.85, 1.15]")
        else:
            raise InvalidParameterError(f"{key} must be a spread (0.15) or two factors [low, high], got "
                                        f"{shown(value)}")
        out[quantity] = (low, high)
    return out


def draw_factors(model, bounds: dict, seed: int, draw: int) -> dict[str, float]:
    """Draw ``draw`` of a study seeded ``seed``: one factor per name of :func:`uncertain_parameters`, uniform
    within its quantity's ``bounds`` (see :func:`check_bounds`). The same arguments give the same factors."""
    bounds = check_bounds(bounds)
    names = uncertain_parameters(model, tuple(bounds))
    rng = np.random.default_rng([int(seed), int(draw)])
    values = rng.random(len(names))
    out = {}
    for name, u in zip(names, values, strict=True):
        low, high = bounds[name.rsplit(".", 1)[1]]
        out[name] = float(low + (high - low) * u)
    return out


def _factor(factors: dict, name: str) -> float:
    return float(factors.get(name, 1.0))


def perturbed_plant(model, factors: dict):
    """``model`` with each body's mass, lengths and inertia multiplied by its factor (missing factors are
    1). Raises :class:`~pkmlab.errors.InvalidParameterError` naming the first unknown factor, or when the
    machine drawn cannot be assembled."""
    known = set(uncertain_parameters(model))
    for name in factors:
        if name not in known:
            raise InvalidParameterError(f"unknown uncertain parameter '{name}' (e.g. {', '.join(sorted(known)[:3])})")
    from ..model.mechanism_model import MechanismModel

    description = model.description
    legs = []
    for i, leg in enumerate(description.legs):
        bodies = tuple(_scaled_body(body, factors, f"leg{i + 1}.body{j + 1}") for j, body in enumerate(leg.bodies))
        legs.append(dataclasses.replace(leg, bodies=bodies))
    p = description.platform
    length = _factor(factors, "platform.length")
    platform = dataclasses.replace(
        p, attachments=tuple(tuple(c * length for c in a) for a in p.attachments),
        com=tuple(c * length for c in p.com), mass=p.mass * _factor(factors, "platform.mass"),
        inertia=_scaled_inertia(p.inertia, _factor(factors, "platform.inertia")))
    return MechanismModel.from_description(dataclasses.replace(description, legs=tuple(legs), platform=platform))


def _scaled_inertia(inertia, factor: float):
    if isinstance(inertia, tuple):  # a spatial body's tensor
        return tuple(tuple(c * factor for c in row) for row in inertia)
    return inertia * factor


def _scaled_body(body, factors: dict, name: str):
    length = _factor(factors, f"{name}.length")
    return dataclasses.replace(body, tip=tuple(c * length for c in body.tip), com=tuple(c * length for c in body.com),
                               mass=body.mass * _factor(factors, f"{name}.mass"),
                               inertia=_scaled_inertia(body.inertia, _factor(factors, f"{name}.inertia")))
