"""The JSON Schemas of the TOML files: shipped as the key tables give them, every example file valid against its
schema, and the loaders and the schemas refusing the same bad files."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import jsonschema
import pytest

from pkmlab.description.files import load_mechanism, mechanism_from_dict
from pkmlab.errors import PkmlabDeprecationWarning, PkmlabError
from pkmlab.formats import schemas
from pkmlab.formats.scenario import SCENARIO_DIR, scenario_from_dict
from pkmlab.study.definition import study_from_dict

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def validator(kind: str):
    """A validator of the shipped schema of ``kind`` (the file a user's editor reads)."""
    return jsonschema.Draft7Validator(json.loads(schemas.path(kind).read_text(encoding="utf-8")))


def kind_of(data: dict) -> str:
    """Which format a TOML file is, by its tables: a study has [study], a scenario [trajectory]."""
    if "study" in data:
        return "sweep"
    return "scenario" if "trajectory" in data else "description"


def schema_errors(kind: str, data: dict) -> list[str]:
    return [f"{list(e.absolute_path)}: {e.message}" for e in validator(kind).iter_errors(data)]


# ------------------------------------------------------------------ the shipped files
@pytest.mark.parametrize("kind", schemas.KINDS)
def test_shipped_schema_is_current(kind):
    """The shipped file is what the key tables give now (python -m pkmlab.formats.schemas --write otherwise)."""
    assert schemas.path(kind).read_text(encoding="utf-8") == schemas.schema_text(kind)


@pytest.mark.parametrize("kind", schemas.KINDS)
def test_shipped_schema_is_a_draft7_schema(kind):
    schema = json.loads(schemas.path(kind).read_text(encoding="utf-8"))
    jsonschema.Draft7Validator.check_schema(schema)
    assert schema["$schema"] == "http://json-schema.org/draft-07/schema#"


def test_check_finds_a_stale_or_missing_schema(tmp_path):
    assert schemas.stale() == []
    assert schemas.main(["--check"]) == 0
    written = schemas.write(tmp_path)
    assert sorted(p.name for p in written) == ["description.schema.json", "scenario.schema.json",
                                              "sweep.schema.json"]
    assert schemas.stale(tmp_path) == []
    (tmp_path / "scenario.schema.json").write_text("{}\n")
    (tmp_path / "sweep.schema.json").unlink()
    assert schemas.stale(tmp_path) == ["scenario", "sweep"]


def test_schemas_are_package_data():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "schemas/*.schema.json" in pyproject["tool"]["setuptools"]["package-data"]["pkmlab"]
    assert schemas.path("sweep").parent == Path(schemas.__file__).resolve().parents[1] / "schemas"
    with pytest.raises(PkmlabError, match="kind must be one of"):
        schemas.path("scenarios")


def test_keys_carry_documentation():
    """Every key of every table has a type and a description; a key with a unit says it; refs point at
    definitions."""
    schema = json.loads(schemas.path("sweep").read_text(encoding="utf-8"))
    tables = [d for d in schema["definitions"].values() if "properties" in d]
    assert len(tables) > 15
    for table in tables:
        for name, prop in table["properties"].items():
            if prop is not False and "$ref" not in prop:  # a table's own definition has its description
                assert prop.get("description"), name
                assert prop.get("type"), name
    kp = schema["definitions"]["controller"]["properties"]["kp"]
    assert kp["default"] == 1000.0 and kp["exclusiveMinimum"] == 0 and "1/s^2" in kp["description"]
    assert schema["definitions"]["planar_body"]["properties"]["mass"]["description"].endswith("Unit: kg.")
    refs = set(re.findall(r'"#/definitions/(\w+)"', json.dumps(schema)))
    assert refs and refs <= set(schema["definitions"])


# ------------------------------------------------------------------ the repository's files
EXAMPLE_FILES = sorted([*EXAMPLES.rglob("*.toml"), *SCENARIO_DIR.glob("*.toml")])


def test_the_examples_cover_every_format():
    """The files below are found (the glob is right), and each format has examples to check."""
    kinds = [kind_of(tomllib.loads(p.read_text(encoding="utf-8"))) for p in EXAMPLE_FILES]
    assert ROOT / "examples/mechanisms/3rps.toml" in EXAMPLE_FILES
    assert SCENARIO_DIR / "nominal.toml" in EXAMPLE_FILES
    assert all(kinds.count(k) >= 3 for k in schemas.KINDS), kinds


@pytest.mark.parametrize("path", EXAMPLE_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_example_file_is_valid_against_its_schema(path):
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    kind = kind_of(data)
    assert schema_errors(kind, data) == []
    if kind == "description":  # cheap to read: the loader agrees
        load_mechanism(path)


# ------------------------------------------------------------------ bad files: both refuse
def loader_error(kind: str, data: dict) -> str:
    """The loader's message for ``data``, or "" if it accepts it."""
    try:
        if kind == "description":
            if "mechanism" not in data:
                return "no [mechanism] table"
            mechanism_from_dict(data["mechanism"])
        elif kind == "scenario":
            scenario_from_dict(data, str(EXAMPLES / "scenario.toml"))
        else:
            study_from_dict(data, str(EXAMPLES / "sweep.toml"))  # [study].base relative to examples/
    except PkmlabError as exc:
        return str(exc)
    return ""


PLANAR = """
[mechanism]
name = "five bar"
[mechanism.platform]
kind = "point"
mass = 0.1
[[mechanism.leg]]
base = [0.0, 0.0]
joints = "R*RR"
bodies = [{ tip = [0.2, 0.0], mass = 0.5, com = [0.1, 0.0], inertia = 1e-3 },
          { tip = [0.25, 0.0], mass = 0.5, com = [0.12, 0.0], inertia = 1e-3 }]
[[mechanism.leg]]
base = [0.3, 0.0]
joints = "R*RR"
bodies = [{ tip = [0.2, 0.0], mass = 0.5, com = [0.1, 0.0], inertia = 1e-3 },
          { tip = [0.25, 0.0], mass = 0.5, com = [0.12, 0.0], inertia = 1e-3 }]
"""
SCENARIO = """
[trajectory]
type = "circle"
center = [0.25, 0.21]
radius = 0.05
speed = 0.2
"""
SWEEP = """
[study]
base = "fast.toml"
[grid]
"controller.kp" = [500.0, 1000.0]
"trajectory.speed" = { start = 0.2, stop = 0.4, num = 3 }
"""
BASES = {"description": PLANAR, "scenario": SCENARIO, "sweep": SWEEP}


@pytest.mark.parametrize("kind", schemas.KINDS)
def test_the_bad_files_bases_are_good(kind):
    """The files the bad ones are made from are accepted by both: a refusal below is the change's doing."""
    data = tomllib.loads(BASES[kind])
    assert loader_error(kind, data) == ""
    assert schema_errors(kind, data) == []


def changed(kind: str, edit) -> dict:
    data = tomllib.loads(BASES[kind])
    edit(data)
    return data


def setter(path: str, value):
    def edit(data):
        *tables, last = path.split("/")
        node = data
        for t in tables:
            node = node[int(t)] if isinstance(node, list) else node.setdefault(t, {})
        node[last] = value
    return edit


def remover(path: str):
    def edit(data):
        *tables, last = path.split("/")
        node = data
        for t in tables:
            node = node[int(t)] if isinstance(node, list) else node[t]
        del node[last]
    return edit


def both(*edits):
    def edit(data):
        for e in edits:
            e(data)
    return edit


# (kind, what is wrong, the edit, a word of the loader's message)
BAD = [
    ("description", "no [mechanism]", remover("mechanism"), "no [mechanism]"),
    ("description", "unknown key", setter("mechanism/colour", "red"), "colour"),
    ("description", "empty name", setter("mechanism/name", ""), "name"),
    ("description", "typo'd key", both(remover("mechanism/leg/0/joints"), setter("mechanism/leg/0/joint", "R*RR")),
     "joint"),
    ("description", "missing platform", remover("mechanism/platform"), "platform is required"),
    ("description", "wrong type", setter("mechanism/leg/0/bodies/0/mass", "0.5"), "mass"),
    ("description", "negative mass", setter("mechanism/leg/0/bodies/0/mass", -0.5), "mass"),
    ("description", "unknown joint", setter("mechanism/leg/1/joints", "X*RR"), "joints"),
    ("description", "preset and a description", setter("mechanism/preset", "paper"), "either preset"),
    ("description", "unknown preset", lambda d: d.__setitem__("mechanism", {"preset": "papr"}), "preset"),
    ("description", "dimension 4", setter("mechanism/dimension", 4), "dimension"),
    ("description", "a planar platform's kind in a spatial machine", setter("mechanism/dimension", 3), "kind"),
    ("description", "unknown platform key", setter("mechanism/platform/spin", 1.0), "spin"),
    ("description", "unknown platform kind", setter("mechanism/platform/kind", "soft"), "kind"),
    ("description", "a point for gravity in the plane", setter("mechanism/gravity", [0.0, 0.0, -9.81]), "gravity"),
    ("scenario", "no [trajectory]", remover("trajectory"), "trajectory"),
    ("scenario", "typo'd table", setter("controler/kp", 500.0), "controler"),
    ("scenario", "typo'd key", setter("controller/kpp", 500.0), "kpp"),
    ("scenario", "a key at top level", setter("kp", 500.0), "kp"),
    ("scenario", "wrong type", setter("controller/kp", "1000"), "kp"),
    ("scenario", "negative gain", setter("controller/kp", -1.0), "kp"),
    ("scenario", "unknown controller", setter("controller/type", "pid"), "type"),
    ("scenario", "unknown trajectory type", setter("trajectory/type", "circel"), "type"),
    ("scenario", "a line's key on a circle", setter("trajectory/start", [0.2, 0.2, 0.0]), "start"),
    ("scenario", "circle without radius", remover("trajectory/radius"), "radius"),
    ("scenario", "circle without speed", remover("trajectory/speed"), "speed"),
    ("scenario", "zero speed", setter("trajectory/speed", 0.0), "speed"),
    ("scenario", "unknown time law", setter("trajectory/time_law", "linear"), "time_law"),
    ("scenario", "a spatial circle's normal on a planar one", setter("trajectory/normal", [0.0, 0.0, 1.0]), "normal"),
    ("scenario", "a planar circle's alpha on a spatial one",
     both(setter("trajectory/center", [0.0, 0.0, -0.8]), setter("trajectory/alpha", 0.1)), "alpha"),
    ("scenario", "line without end",
     lambda d: d.__setitem__("trajectory", {"type": "line", "start": [0.2, 0.2, 0.0], "speed": 0.1}), "end"),
    ("scenario", "spline with a time law",
     lambda d: d.__setitem__("trajectory", {"type": "spline", "points": [[0.2, 0.2, 0.0], [0.25, 0.2, 0.0]],
                                            "durations": [1.0], "time_law": "cubic"}), "time_law"),
    ("scenario", "spline without durations",
     lambda d: d.__setitem__("trajectory", {"type": "spline", "points": [[0.2, 0.2, 0.0], [0.25, 0.2, 0.0]]}),
     "durations"),
    ("scenario", "waypoints with speed and durations",
     lambda d: d.__setitem__("trajectory", {"type": "waypoints", "points": [[0.2, 0.2, 0.0], [0.25, 0.2, 0.0]],
                                            "durations": [1.0], "speed": 0.1}), "speed"),
    ("scenario", "fourier with a speed",
     lambda d: d.__setitem__("trajectory", {"type": "fourier", "center": [0.25, 0.21, 0.0], "period": 2.0,
                                            "a": [[0.0, 0.0, 0.0]], "b": [[0.0, 0.0, 0.0]], "speed": 0.1}),
     "speed"),
    ("scenario", "both [manipulator] and [mechanism]",
     both(setter("manipulator/preset", "paper"), setter("mechanism/preset", "paper")), "both"),
    ("scenario", "a mechanism file and a preset",
     both(setter("mechanism/file", "mechanisms/3rps.toml"), setter("mechanism/preset", "paper")), "file"),
    ("scenario", "unknown key of an inline mechanism", setter("mechanism/colour", "red"), "colour"),
    ("scenario", "unknown parameter of [manipulator]", setter("manipulator/params/length", 0.2), "length"),
    ("scenario", "zero mass scale", setter("plant/mass_scale", 0.0), "mass_scale"),
    ("scenario", "a negative gear ratio", setter("plant/gear_ratio", [1.0, -2.0, 1.0]), "gear_ratio"),
    ("scenario", "a plant's effort limit in [controller]", setter("controller/effort_limit", 1.0), "effort_limit"),
    ("scenario", "stick-slip not a flag", setter("plant/stick_slip", 1), "stick_slip"),
    ("scenario", "unknown sensed rates", setter("sensors/rates", "exactly"), "rates"),
    ("scenario", "sensors' delay too long", setter("sensors/delay", 5000), "delay"),
    ("scenario", "substeps a string", setter("simulation/substeps", "2"), "substeps"),
    ("scenario", "negative seed", setter("simulation/seed", -1), "seed"),
    ("scenario", "[timing] without a limit", setter("timing/grid", 100), "at least one limit"),
    ("scenario", "[timing] grid too fine", both(setter("timing/velocity", 3.0), setter("timing/grid", 5)), "grid"),
    ("sweep", "typo'd table", setter("grd/controller.kp", [1.0]), "grd"),
    ("sweep", "typo'd key of [study]", setter("study/jobb", "identify"), "jobb"),
    ("sweep", "no base", remover("study/base"), "base"),
    ("sweep", "two bases", setter("base/trajectory", {"type": "circle", "center": [0.25, 0.21], "radius": 0.05,
                                                     "speed": 0.2}), "base"),
    ("sweep", "an inline base without its trajectory",
     both(remover("study/base"), setter("base/controller/kp", 500.0)), "trajectory"),
    ("sweep", "unknown axis", setter("grid/controller.kpp", [1.0, 2.0]), "kpp"),
    ("sweep", "the machine as an axis", setter("grid/mechanism.preset", ["paper", "five_bar"]), "mechanism.preset"),
    ("sweep", "an axis of the wrong type", setter("grid/controller.kp", ["fast", "slow"]), "kp"),
    ("sweep", "empty axis", setter("grid/controller.kp", []), "empty"),
    ("sweep", "unknown key of a range", setter("grid/trajectory.speed/steps", 3), "steps"),
    ("sweep", "range without num", remover("grid/trajectory.speed/num"), "num"),
    ("sweep", "negative draws", setter("study/draws", -1), "draws"),
    ("sweep", "unknown combine", setter("study/combine", "product"), "combine"),
    ("sweep", "unknown job", setter("study/job", "optimize"), "job"),
    ("sweep", "unknown quantity", both(setter("study/draws", 2), setter("uncertainty/masss", 0.1)), "masss"),
    ("sweep", "spread too large", both(setter("study/draws", 2), setter("uncertainty/mass", 1.5)), "spread"),
    ("sweep", "calibration options of a simulation", setter("calibration/poses", 20), "calibration"),
    ("sweep", "identification axis of a calibration",
     both(setter("study/job", "calibrate"), setter("grid/identification.window", [0.1])),
     "identification.window"),
    ("sweep", "unknown calibration option",
     both(setter("study/job", "calibrate"), setter("calibration/posess", 20)), "posess"),
    ("sweep", "a calibration count not whole",
     both(setter("study/job", "calibrate"), setter("calibration/poses", 0)), "poses"),
]


@pytest.mark.parametrize(("kind", "what", "edit", "word"), BAD, ids=[f"{k}: {w}" for k, w, _e, _word in BAD])
def test_loader_and_schema_both_refuse(kind, what, edit, word):
    data = changed(kind, edit)
    message = loader_error(kind, data)
    assert word in message, f"{what}: the loader says {message!r}"
    assert schema_errors(kind, data), f"{what}: the loader refuses ({message}), the schema accepts"


# ------------------------------------------------------------------ good files beyond the examples: both accept
GOOD = [
    ("description", "a preset", lambda d: d.__setitem__("mechanism", {"preset": "delta"})),
    ("description", "defaults left out", both(remover("mechanism/name"), remover("mechanism/platform/mass"))),
    ("description", "spaces in the joints", setter("mechanism/leg/0/joints", "R* R R")),
    ("scenario", "timed waypoints",
     lambda d: d.__setitem__("trajectory", {"type": "waypoints", "points": [[0.2, 0.2, 0.0], [0.25, 0.2, 0.1]],
                                            "durations": [1.0]})),
    ("scenario", "a line, quintic", lambda d: d.__setitem__("trajectory", {
        "type": "line", "start": [0.22, 0.2, 0.0], "end": [0.27, 0.2, 0.0], "speed": 0.1, "time_law": "quintic"})),
    ("scenario", "every optional table", both(
        setter("plant/mass_scale", 1.1), setter("plant/gear_ratio", [1.0, 2.0, 1.0]), setter("plant/stick_slip", True),
        setter("sensors/resolution", 1e-4), setter("sensors/rates", "exact"), setter("controller/type", "pd"),
        setter("controller/kv", 0.0), setter("simulation/working_mode", "+-+"), setter("simulation/seed", 3),
        setter("timing/velocity", [3.0, 3.0, 3.0]))),
    ("scenario", "signs as a list", setter("simulation/working_mode", [1, -1, 1])),
    ("scenario", "continuous-time control", setter("controller/sample_time", 0)),
    ("scenario", "the deprecated [manipulator]", setter("manipulator/preset", "paper")),
    ("sweep", "zipped axes", both(setter("study/combine", "zip"),
                                  setter("grid/trajectory.speed", {"start": 0.2, "stop": 0.4, "num": 2}))),
    ("sweep", "an inline base", both(remover("study/base"), setter("base/trajectory", {
        "type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2}))),
    ("sweep", "a count on a range", setter("grid/simulation.substeps", {"start": 1, "stop": 3, "num": 3})),
    ("sweep", "a log range", setter("grid/controller.sample_time", {"start": 5e-4, "stop": 2e-3, "num": 3,
                                                                    "scale": "log"})),
    ("sweep", "drawn plants", both(setter("study/draws", 2), setter("uncertainty/length", [0.95, 1.05]))),
    ("sweep", "an identification's options", both(setter("study/job", "identify"), setter("identification/window", 0.1),
                                                  setter("grid/identification.polyorder", [3, 4]))),
]


@pytest.mark.parametrize(("kind", "what", "edit"), GOOD, ids=[f"{k}: {w}" for k, w, _e in GOOD])
def test_loader_and_schema_both_accept(kind, what, edit):
    data = changed(kind, edit)
    if "manipulator" in data:  # read still, with a warning
        with pytest.warns(PkmlabDeprecationWarning, match="deprecated"):
            assert loader_error(kind, data) == ""
    else:
        assert loader_error(kind, data) == ""
    assert schema_errors(kind, data) == []
