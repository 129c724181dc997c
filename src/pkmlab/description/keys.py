"""The keys of a description file's ``[mechanism]`` table, planar and spatial (:mod:`pkmlab.description.files`
reads them; :mod:`pkmlab.formats.schemas` writes them as a JSON Schema)."""

from __future__ import annotations

from .._keys import NUMBER, POINT, VECTOR, Key

_STROKE = {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 2}
#: A 3x3 tensor, or one number for that number times the identity.
_TENSOR = {"type": ["number", "array"], "anyOf": [{"type": "number", "minimum": 0},
                     {"type": "array", "minItems": 3, "maxItems": 3, "items": VECTOR}]}

#: The keys of ``[mechanism]`` before its kind is known: a preset, or a planar or spatial description.
MECHANISM = (
    Key("preset", "string", "A preset machine of pkmlab; no other key may be given with it.",
        examples=("paper", "delta")),
    Key("name", "string", "The machine's name.", default="mechanism", examples=("3-RRR",),
        schema={"type": "string", "minLength": 1}),
    Key("dimension", "integer", "2 for a planar machine (in the x-y plane), 3 for a spatial one.", default=2,
        schema={"type": "integer", "enum": [2, 3]}),
    Key("gravity", "array", "The gravity vector [gx, gy] in the plane of a planar machine.", "m/s^2",
        default=(0.0, 0.0), schema=POINT),
    Key("platform", "table", "The moving platform ([mechanism.platform]).", required=True),
    Key("leg", "array", "The legs, from the base to the platform, one [[mechanism.leg]] table each.", required=True),
)

PLANAR_PLATFORM = (
    Key("kind", "string", "'rigid' (pose x, y, alpha) or 'point' (pose x, y: every leg ends at one point).",
        default="rigid", choices=("rigid", "point")),
    Key("attachments", "array", "Where each leg meets a rigid platform, [x, y] in the platform frame, one per leg.",
        "m", default=(), schema={"type": "array", "items": POINT}),
    Key("mass", "number", "The platform's mass (positive for a rigid platform; a point platform's payload).", "kg",
        default=0.0, sign="non-negative"),
    Key("com", "array", "The platform's mass centre, [x, y] in the platform frame.", "m", default=(0.0, 0.0),
        schema=POINT),
    Key("inertia", "number", "The platform's moment of inertia about its mass centre (positive for a rigid "
        "platform).", "kg m^2", default=0.0, sign="non-negative"),
)
PLANAR_BODY = (
    Key("tip", "array", "Where the next joint sits, [x, y] in the body's frame (origin at the joint that moves it, "
        "x along the body).", "m", default=(0.0, 0.0), schema=POINT),
    Key("mass", "number", "The body's mass.", "kg", required=True, sign="positive"),
    Key("com", "array", "The body's mass centre, [x, y] in its frame.", "m", default=(0.0, 0.0), schema=POINT),
    Key("inertia", "number", "The body's moment of inertia about its mass centre (positive if it rotates).",
        "kg m^2", default=0.0, sign="non-negative"),
)
PLANAR_LEG = (
    Key("base", "array", "The leg's base point [x, y].", "m", required=True, schema=POINT),
    Key("joints", "string", "The leg's joints from the base to the platform, R (revolute) or P (prismatic), the "
        "actuated one starred (a kinematically redundant leg's first joints too, moving the base of the rest; a "
        "second actuator in the leg's last three joints makes the machine redundantly actuated); the last is a "
        "passive R.", required=True, examples=("R*RR", "RP*R", "P*RR", "P*R*RR", "R*R*R"),
        schema={"type": "string", "pattern": r"^ *([RP] *(\* *)?)+$"}),
    Key("axis", "number", "A prismatic first joint's rail: its absolute angle from the base x axis.", "rad"),
    Key("stroke", "array", "The stroke [lower, upper] of the leg's own actuator, the first actuated joint among its "
        "last three (rad or m); none: no limit.", schema=_STROKE),
    Key("bodies", "array", "The leg's bodies, one after each joint but the last.", default=[]),
)

SPATIAL_PLATFORM = (
    Key("kind", "string", "'translating' (pose x, y, z; its orientation held by the legs) or 'rigid' (pose x, y, z, "
        "roll, pitch, yaw).", default="rigid", choices=("translating", "rigid")),
    Key("attachments", "array", "Where each leg meets the platform, [x, y, z] in the platform frame, one per leg.",
        "m", default=(), schema={"type": "array", "items": VECTOR}),
    Key("mass", "number", "The platform's mass.", "kg", default=0.0, sign="non-negative"),
    Key("com", "array", "The platform's mass centre, [x, y, z] in the platform frame.", "m", default=(0.0, 0.0, 0.0),
        schema=VECTOR),
    Key("inertia", "array", "The platform's inertia tensor about its mass centre, 3x3 in its frame, or one number "
        "I for I times the identity.", "kg m^2", default=0.0, schema=_TENSOR),
    Key("controlled", "array", "A rigid platform on fewer than six legs: the pose coordinates its actuators "
        "control (the others are parasitic).", examples=(("z", "roll", "pitch"),),
        schema={"type": "array", "items": {"type": "string", "enum": ["x", "y", "z", "roll", "pitch", "yaw"]},
                "uniqueItems": True}),
)
SPATIAL_BODY = (
    Key("tip", "array", "Where the next joint sits, [x, y, z] in the body's frame (zero configuration).", "m",
        default=(0.0, 0.0, 0.0), schema=VECTOR),
    Key("mass", "number", "The body's mass.", "kg", required=True, sign="positive"),
    Key("com", "array", "The body's mass centre, [x, y, z] in its frame.", "m", default=(0.0, 0.0, 0.0),
        schema=VECTOR),
    Key("inertia", "array", "The body's inertia tensor about its mass centre, 3x3 in its frame, or one number I for "
        "I times the identity.", "kg m^2", default=0.0, schema=_TENSOR),
)
SPATIAL_LEG = (
    Key("base", "array", "The leg's base point [x, y, z].", "m", required=True, schema=VECTOR),
    Key("joints", "string", "The leg's joints from the base to the platform, R, P, U (universal) or S (spherical), "
        "the actuated one (R or P) starred (a second starred makes the machine redundantly actuated); the last "
        "carries the platform.", required=True, examples=("UP*S", "R*US", "P*US", "R*R*S"),
        schema={"type": "string", "pattern": r"^ *([RPUS] *(\* *)?)+$"}),
    Key("axes", "array", "One entry per joint but an S: a vector [x, y, z] for R and P, a pair of perpendicular "
        "vectors for U (zero configuration).", default=[],
        schema={"type": "array", "items": {"anyOf": [VECTOR, {"type": "array", "items": VECTOR, "minItems": 2,
                                                                "maxItems": 2}]}}),
    Key("stroke", "array", "The stroke [lower, upper] of the leg's own actuator, its first actuated joint (rad or "
        "m); none: no limit.", schema=_STROKE),
    Key("bodies", "array", "The leg's bodies, one after each joint but the last.", default=[]),
)
#: The keys of a spatial ``[mechanism]`` (``dimension = 3``).
SPATIAL_MECHANISM = tuple(
    Key("gravity", "array", "The gravity vector [gx, gy, gz], e.g. [0, 0, -9.81] for a machine working against "
        "gravity.", "m/s^2", default=(0.0, 0.0, 0.0), schema=VECTOR) if k.name == "gravity" else k
    for k in MECHANISM if k.name not in ("preset", "dimension"))
