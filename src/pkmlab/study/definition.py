"""What a study is: a base scenario, axes crossed as a grid, Monte Carlo draws of the plant.

A study file (``pkmlab sweep SWEEP.toml``) is declarative TOML, like a scenario file::

    [study]
    name = "fast_gain_sweep"
    base = "fast.toml"        # a scenario file (relative to this file), or inline [base.*] tables
    draws = 20                # plants drawn per grid point (0: the plant of the scenario, once)
    seed = 2026

    [grid]                    # every combination of the axes' values, the first axis slowest
    "controller.kp" = [250.0, 500.0, 1000.0, 2000.0]
    "trajectory.speed" = { start = 0.2, stop = 0.6, num = 5 }            # evenly spaced, ends included
    "controller.sample_time" = { start = 5e-4, stop = 2e-3, num = 3, scale = "log" }

    [uncertainty]             # per body, uniform (pkmlab.simulation.uncertainty): a spread or [low, high] factors
    mass = 0.15
    length = [0.9, 1.1]

With ``combine = "zip"`` in ``[study]`` the axes are not crossed but paired, value by value (all of
one length): points ``(kp, kv)`` chosen together, as a tuner does.

With ``job = "identify"`` or ``job = "calibrate"`` in ``[study]`` a run identifies the plant from its
simulated log, or calibrates a machine built with errors, with the options of an ``[identification]`` or a
``[calibration]`` table, each of them an axis too (``"calibration.noise" = [1e-6, 1e-5]``):
:mod:`pkmlab.study.jobs`.

An axis is any value of a scenario file, written ``table.key`` (``controller.kp``,
``trajectory.speed``, ``controller.sample_time``, ``plant.mass_scale``, ``simulation.substeps``,
``manipulator.params.l`` ...); the machine itself is the base's. Runs are numbered grid point by grid
point, draws innermost: run ``r`` is draw ``r % D`` of grid point ``r // D`` (``D = max(draws, 1)``).

A :class:`Study` is immutable and self-contained (the base scenario and any mechanism file it names are
read once, into the study), so it can be sent to the workers of a cluster that do not share the
user's files; its :attr:`~Study.digest` identifies what it computes (base, axes, draws, seed, pkmlab's
version), and a study folder is only ever resumed by the study that wrote it.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._files import read_toml
from .._format import suggestion
from .._keys import defaults
from .._keys import key as declared
from .._version import __version__
from ..errors import FileFormatError, InvalidParameterError, PkmlabError, shown
from ..formats.scenario import scenario_from_dict
from ..formats.study_keys import (
    JOBS,
    RANGE,
    RANGE_KEYS,
    STUDY,
    STUDY_KEYS,
    STUDY_TABLES,
    TABLE,
    axis_keys,
    option_keys,
)
from ..simulation.uncertainty import check_bounds
from .jobs import COUNTS, OPTIONS, check_option, job_options

#: How a study's axes make its points: every combination, or value by value.
COMBINE = declared(STUDY, "combine").choices
#: The defaults of ``[study]`` and of a range (declared in :mod:`pkmlab.formats.study_keys`).
_STUDY_DEFAULTS, _RANGE_DEFAULTS = defaults(STUDY), defaults(RANGE)
#: At most this many runs in one study (the table's memory: about 1 kB per run).
MAX_RUNS = 50_000_000
#: Axes whose values are counts (kept as integers).
INTEGER_KEYS = ("simulation.substeps", "trajectory.periods",
                *(f"{table}.{key}" for job, table in TABLE.items() for key in COUNTS if key in OPTIONS[job]))


def _error(source: str, text: str) -> InvalidParameterError:
    return InvalidParameterError(f"{source}: {text}")


def _finite_value(value) -> bool:
    if isinstance(value, bool) or isinstance(value, str):
        return True
    if isinstance(value, (int, float)):
        return math.isfinite(float(value))
    if isinstance(value, list):
        return all(_finite_value(v) for v in value)
    return True


def axis_values(key: str, spec, source: str = "<study>", unique: bool = True) -> tuple:
    """The values of axis ``key``: a non-empty list as given, or a range ``{start, stop, num}``
    (``scale = "linear"`` evenly spaced, ``"log"`` geometrically; ``num = 1`` gives ``start``). Crossed axes
    (``unique``) may not repeat a value: the same runs twice."""
    where = f"[grid].{json.dumps(key)}"
    if isinstance(spec, dict):
        for k in spec:
            if k not in RANGE_KEYS:
                raise _error(source, f"unknown key '{k}' in the range {where}{suggestion(str(k), RANGE_KEYS)}")
        missing = [k.name for k in RANGE if k.required and k.name not in spec]
        if missing:
            raise _error(source, f"the range {where} needs {', '.join(missing)} (a range is {{start, stop, num}})")
        start, stop, num = spec["start"], spec["stop"], spec["num"]
        for name, v in (("start", start), ("stop", stop)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                raise _error(source, f"{where}.{name} must be a finite number, got {shown(v)}")
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise _error(source, f"{where}.num must be a positive integer, got {shown(num)}")
        scale = spec.get("scale", _RANGE_DEFAULTS["scale"])
        if scale not in declared(RANGE, "scale").choices:
            raise _error(source, f"{where}.scale must be \"linear\" or \"log\", got {shown(scale)}")
        if num > MAX_RUNS:
            raise _error(source, f"{where}.num = {num}: more values than a study may run ({MAX_RUNS})")
        if scale == "log":
            if start <= 0 or stop <= 0:
                raise _error(source, f"the log range {where} needs start and stop > 0, got {start} and {stop}")
            values = np.geomspace(float(start), float(stop), num)
        else:
            values = np.linspace(float(start), float(stop), num)
        if key in INTEGER_KEYS:  # a count: the range's values must be whole
            if not np.allclose(values, np.round(values), rtol=0, atol=1e-9):
                raise _error(source, f"the range {where} must give whole numbers ({key} is a count), got "
                             f"{shown([float(v) for v in values])}")
            spec = [int(round(float(v))) for v in values]
        else:
            spec = [float(v) for v in values]
    elif isinstance(spec, list):
        spec = [v.item() if isinstance(v, np.generic) else v for v in spec]
    else:
        raise _error(source, f"{where} must be a list of values or a range {{start, stop, num}}, got {shown(spec)}")
    if not spec:
        raise _error(source, f"{where} is empty: give at least one value")
    for i, v in enumerate(spec):
        if not _finite_value(v):
            raise _error(source, f"{where}[{i}] must be finite, got {shown(v)}")
        if not isinstance(v, (bool, int, float, str, list)):
            raise _error(source, f"{where}[{i}] must be a number, a string, a boolean or a list, got {shown(v)}")
    kinds = {_kind(v) for v in spec}
    if len(kinds) > 1:
        raise _error(source, f"{where} mixes {' and '.join(sorted(kinds))}: give values of one kind, got "
                     f"{shown(list(spec))}")
    values = tuple(float(v) if isinstance(v, int) and not isinstance(v, bool) and key not in INTEGER_KEYS
                   else v for v in spec)
    if unique and len({json.dumps(v) for v in values}) != len(values):
        raise _error(source, f"{where} repeats a value: {shown(list(spec))}")
    return values


def _kind(value) -> str:
    """The kind of an axis value, for the table's column type: numbers, booleans, strings or lists."""
    if isinstance(value, bool):
        return "booleans"
    if isinstance(value, (int, float)):
        return "numbers"
    return "strings" if isinstance(value, str) else "lists"


def _set(data: dict, key: str, value) -> None:
    *tables, last = key.split(".")
    node = data
    for name in tables:
        node = node.setdefault(name, {})
    node[last] = value


def _self_contained(base: dict, folder: Path, source: str) -> dict:
    """``base`` with a ``[mechanism].file`` read into it, so that the study needs no file of the user's."""
    base = copy.deepcopy(base)
    mechanism = base.get("mechanism")
    if isinstance(mechanism, dict) and "file" in mechanism:
        path = mechanism["file"]
        if not isinstance(path, str) or not path:
            raise _error(source, f"[mechanism].file must be a file name, got {shown(path)}")
        data = read_toml(folder / path)
        if not isinstance(data.get("mechanism"), dict):
            raise _error(source, f"{path}: no [mechanism] table")
        base["mechanism"] = data["mechanism"]
    return base


def scenario_tables(scenario, source: str = "<scenario>", what: str = "scenario") -> dict:
    """A scenario's tables, from a scenario file or from its tables (a dict; a ``[mechanism].file`` in it is
    relative to ``source``'s folder), with any mechanism file read into them: what a study or a tuning sends to
    workers that do not share the user's files. Errors start with ``what``."""
    if not isinstance(scenario, (str, Path, dict)):
        raise InvalidParameterError(f"{what} must be a scenario file or its tables (a dict), got "
                                    f"{type(scenario).__name__} {shown(scenario, 40)}")
    try:
        if isinstance(scenario, dict):
            return _self_contained(scenario, Path(source).parent, source)
        path = Path(scenario)
        return _self_contained(read_toml(path), path.parent, str(path))
    except PkmlabError as exc:
        raise type(exc)(f"{what}: {exc}") from None
    except ValueError as exc:  # a NUL in a path
        raise InvalidParameterError(f"{what}: {exc}") from None


@dataclass(frozen=True)
class Study:
    """A study: runs of ``base`` at every point of the grid of ``axes`` and, per point, ``draws`` plants.

    ``base`` is scenario data, as a scenario file's tables; the plants are drawn within ``uncertainty`` (see
    :mod:`pkmlab.simulation.uncertainty`). Build one with :func:`load_study` (a study file) or :meth:`create`,
    which check it; run it with :func:`~pkmlab.sweep`.

    Attributes
    ----------
    base : dict
        The base scenario's tables.
    axes : tuple of (str, tuple)
        Each axis's key (``"controller.kp"``) and values.
    uncertainty : dict
        The drawn quantities' bounds, ``{quantity: (low, high)}`` factors.
    draws : int
        Plants drawn per grid point (0: the scenario's plant, once).
    seed : int
        The draws' seed.
    name : str
        The study's name.
    source : str
        The study file's name (or ``"<study>"``), at the start of every error message.
    combine : {"cross", "zip"}
        Every combination of the axes' values, or value by value.
    job : str
        What a run does (``"simulate"``, ``"identify"``, ``"calibrate"``).
    options : dict
        The job's options (:mod:`pkmlab.study.jobs`).

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.formats.scenario import SCENARIO_DIR
    >>> study = pkmlab.Study.create(SCENARIO_DIR / "fast.toml", grid={"controller.kp": [500.0, 1000.0]},
    ...                             uncertainty={"mass": 0.15}, draws=3, seed=1)
    >>> study.name, study.shape, study.size
    ('fast', (2,), 6)
    >>> study.point_values(1), study.locate(4)
    ({'controller.kp': 1000.0}, (1, 1))
    """

    base: dict
    axes: tuple[tuple[str, tuple], ...] = ()
    uncertainty: dict = field(default_factory=dict)
    draws: int = 0
    seed: int = 0
    name: str = "study"
    source: str = "<study>"
    combine: str = "cross"
    job: str = "simulate"
    options: dict = field(default_factory=dict)

    # ---------------------------------------------------------------- construction
    @classmethod
    def create(cls, base, grid: dict | None = None, uncertainty: dict | None = None, draws: int = 0, seed: int = 0,
               name: str | None = None, source: str = "<study>", combine: str = "cross", job: str = "simulate",
               options: dict | None = None) -> Study:
        """A checked study.

        Parameters
        ----------
        base : str, path or dict
            A scenario file's path, or its tables as a dict.
        grid : dict, optional
            ``{axis key: list of values or {start, stop, num[, scale]}}``; an axis key is ``table.key`` of a scenario
            file (``"controller.kp"``, ``"trajectory.speed"``...).
        uncertainty : dict, optional
            ``{quantity: spread or [low, high]}``, quantities ``mass``, ``length``, ``inertia``.
        draws : int
            Plants drawn per grid point (0: none; needs ``uncertainty`` otherwise).
        seed : int
            The draws' seed, non-negative.
        name : str, optional
            The study's name (default the base file's stem, or the source's).
        source : str
            The study file's name, at the start of every error message.
        combine : {"cross", "zip"}
            ``"cross"``: every combination of the axes' values; ``"zip"``: value by value.
        job : str
            What a run does (:data:`~pkmlab.formats.study_keys.JOBS`).
        options : dict, optional
            The job's options (:mod:`pkmlab.study.jobs`).

        Returns
        -------
        Study

        Raises
        ------
        InvalidParameterError
            Every problem, in one line naming the key and the value (:class:`~pkmlab.errors.FileFormatError` for a
            base file that cannot be read).
        """
        if not isinstance(source, str):
            raise InvalidParameterError(f"source must be a string (the study file's name), got {shown(source)}")
        if not (isinstance(job, str) and job in JOBS):
            raise _error(source, f"[study].job must be one of {', '.join(JOBS)}, got {shown(job)}")
        if options and job not in TABLE:
            raise _error(source, f"options are for the identify and calibrate jobs, not {job!r}")
        try:
            resolved = job_options(job, options or {}, f"[{TABLE[job]}]" if job in TABLE else "options")
        except InvalidParameterError as exc:
            raise _error(source, str(exc)) from None
        if name is not None and not (isinstance(name, str) and name):
            raise _error(source, f"name must be a non-empty string, got {shown(name)}")
        if not (isinstance(combine, str) and combine in COMBINE):
            raise _error(source, f"[study].combine must be \"cross\" or \"zip\", got {shown(combine)}")
        data = scenario_tables(base, source, "base")
        if isinstance(base, (str, Path)):
            name = name or Path(base).stem
        if not isinstance(grid if grid is not None else {}, dict):
            raise _error(source, f"grid must be a table of axes, got {shown(grid)}")
        valid = (*axis_keys(), *option_keys(job))
        axes = []
        for key, spec in (grid or {}).items():
            if key not in valid:
                close = difflib.get_close_matches(str(key), valid, n=1, cutoff=0.5)
                if not close:
                    close = [k for k in valid if k.endswith(f".{key}")][:1]
                hint = f" (did you mean '{close[0]}'?)" if close else f" (axes are table.key, e.g. {valid[0]})"
                raise _error(source, f"[grid]: '{key}' is not a scenario value{hint}")
            axes.append((key, axis_values(key, spec, source, unique=combine == "cross")))
            if key in option_keys(job):
                for i, value in enumerate(axes[-1][1]):
                    try:
                        check_option(job, key.split(".", 1)[1], value, f"[grid].{json.dumps(key)}[{i}]")
                    except InvalidParameterError as exc:
                        raise _error(source, str(exc)) from None
        if isinstance(draws, bool) or not isinstance(draws, int) or draws < 0:
            raise _error(source, f"[study].draws must be a non-negative integer, got {shown(draws)}")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise _error(source, f"[study].seed must be a non-negative integer, got {shown(seed)}")
        try:
            bounds = check_bounds(uncertainty or {}, "[uncertainty]")
        except InvalidParameterError as exc:
            raise _error(source, str(exc)) from None
        if job == "calibrate" and bounds:
            raise _error(source, "[uncertainty] draws plants' masses and lengths; a calibration study draws the "
                         "machine's geometry errors ([calibration].size, angle): leave it out")
        if bounds and draws == 0:
            raise _error(source, "[uncertainty] is given but [study].draws = 0: say how many plants to draw")
        if draws and not bounds and job != "calibrate":
            raise _error(source, f"[study].draws = {draws} but no [uncertainty]: give the quantities to draw "
                         "(mass, length, inertia)")
        if combine == "zip" and len({len(values) for _key, values in axes}) > 1:
            raise _error(source, "[study].combine = \"zip\" pairs the axes value by value: they need as many values "
                         "each, got " + ", ".join(f"{key}: {len(values)}" for key, values in axes))
        study = cls(data, tuple(axes), bounds, draws, seed, name or Path(source).stem or "study", source, combine,
                    job, resolved)
        study.check()
        return study

    def check(self) -> None:
        """Refuse a study whose base, or base with one axis value, is not a valid scenario — naming the axis
        and the value — or that has too many runs. (Combinations of valid values that fail — too many samples,
        an unreachable path — are results of the study, recorded with their reason.)"""
        if self.size > MAX_RUNS:
            raise _error(self.source, f"the study has {self.size} runs (grid points x draws), more than {MAX_RUNS}: "
                         "split it")
        try:
            scenario_from_dict(copy.deepcopy(self.base), self.source, self.name)
        except PkmlabError as exc:
            raise _error(self.source, f"the base scenario: {exc}") from None
        for key, values in self.axes:
            if key in option_keys(self.job):  # checked as the job's options
                continue
            for value in values:
                data = copy.deepcopy(self.base)
                _set(data, key, value)
                try:
                    scenario_from_dict(data, self.source, self.name)
                except PkmlabError as exc:
                    raise _error(self.source, f"[grid] {key} = {shown(value)}: {exc}") from None
        self._check_draws()

    #: Plants drawn before a study starts, to refuse bounds that make none of them usable.
    PREFLIGHT_DRAWS = 8

    def _check_draws(self) -> None:
        """Refuse uncertainty bounds that make every plant tried unassemblable (at the start of the first grid
        point's run): the study would only record failures."""
        from ..errors import AssemblyError, UnstableControlError
        from ..simulation.run import prepare_run

        if not self.draws or self.job == "calibrate":  # a calibration draws geometry errors, not plants
            return
        try:
            nominal = self.nominal_scenario(0)
            prepare_run(nominal)
        except PkmlabError:  # the grid point itself fails: a result of the study, not its bounds' doing
            return
        errors = []
        for draw in range(min(self.draws, self.PREFLIGHT_DRAWS)):
            try:
                prepare_run(self.scenario(draw, nominal))
                return
            except UnstableControlError:
                return
            except (AssemblyError, InvalidParameterError) as exc:
                errors.append(exc)
            except PkmlabError:
                return
        bounds = ", ".join(f"{q} in [{lo:g}, {hi:g}]" for q, (lo, hi) in self.uncertainty.items())
        raise _error(self.source, f"[uncertainty]: none of the first {len(errors)} plants drawn ({bounds}) can be "
                     f"assembled: {errors[0]}")

    # ---------------------------------------------------------------- the runs
    @property
    def shape(self) -> tuple[int, ...]:
        """The grid's shape: one entry per axis (one entry in all when the axes are zipped)."""
        if self.combine == "zip":
            return (len(self.axes[0][1]),) if self.axes else ()
        return tuple(len(values) for _key, values in self.axes)

    @property
    def points(self) -> int:
        """The number of grid points."""
        return math.prod(self.shape)

    @property
    def per_point(self) -> int:
        """Runs per grid point: the draws, or the one plant of the scenario."""
        return max(self.draws, 1)

    @property
    def size(self) -> int:
        """The number of runs: grid points × runs per point."""
        return self.points * self.per_point

    def locate(self, run: int) -> tuple[int, int]:
        """``(grid point, draw)`` of ``run``."""
        if not 0 <= run < self.size:
            raise InvalidParameterError(f"run must be in [0, {self.size}), got {run}")
        return divmod(int(run), self.per_point)

    def point_values(self, point: int) -> dict:
        """The axes' values at grid point ``point``, ``{key: value}``."""
        if self.combine == "zip":
            return {key: values[point] for key, values in self.axes}
        index = np.unravel_index(point, self.shape) if self.axes else ()
        return {key: values[i] for (key, values), i in zip(self.axes, index, strict=True)}

    def point_data(self, point: int) -> dict:
        """The scenario data (tables) of grid point ``point``."""
        data = copy.deepcopy(self.base)
        options = option_keys(self.job)
        for key, value in self.point_values(point).items():
            if key not in options:
                _set(data, key, value)
        return data

    def point_options(self, point: int) -> dict:
        """The job's options at grid point ``point`` (:mod:`pkmlab.study.jobs`)."""
        options = dict(self.options)
        keys = option_keys(self.job)
        for key, value in self.point_values(point).items():
            if key in keys:
                options[key.split(".", 1)[1]] = check_option(self.job, key.split(".", 1)[1], value, key)
        return options

    def nominal_scenario(self, point: int):
        """The scenario of grid point ``point`` with the plant it names (before any draw)."""
        return scenario_from_dict(self.point_data(point), self.source, self.name)

    def factors(self, run: int, scenario=None) -> dict[str, float]:
        """The plant's factors of ``run`` (empty without draws):
        :func:`~pkmlab.simulation.uncertainty.draw_factors` of its
        draw, seeded by the study's seed."""
        from ..simulation.uncertainty import draw_factors

        point, draw = self.locate(run)
        if not self.draws or self.job == "calibrate":
            return {}
        scenario = self.nominal_scenario(point) if scenario is None else scenario
        return draw_factors(scenario.plant_model, self.uncertainty, self.seed, draw)

    def scenario(self, run: int, nominal=None, factors: dict | None = None):
        """The :class:`~pkmlab.simulation.scenario.Scenario` of ``run`` — what ``simulate`` runs to reproduce its row.

        Parameters
        ----------
        run : int
            The run's number (``0 … size - 1``).
        nominal : Scenario, optional
            The grid point's scenario, if already built (:meth:`nominal_scenario`).
        factors : dict, optional
            The plant's factors, if already drawn (:meth:`factors`).

        Returns
        -------
        Scenario
        """
        from ..simulation.uncertainty import perturbed_plant

        point, _draw = self.locate(run)
        nominal = self.nominal_scenario(point) if nominal is None else nominal
        if not self.draws or self.job == "calibrate":
            return nominal.replace(name=f"{self.name} run {run}")
        plant = perturbed_plant(nominal.plant_model, self.factors(run, nominal) if factors is None else factors)
        return nominal.replace(plant=plant, name=f"{self.name} run {run}")

    def base_scenario(self):
        """The base scenario (checked when the study was made): the machine every run's table row describes."""
        return scenario_from_dict(copy.deepcopy(self.base), self.source, self.name)

    def factor_names(self) -> tuple[str, ...]:
        """The names of the drawn factors (the table's ``plant.*`` columns), from the base's plant."""
        from ..simulation.uncertainty import uncertain_parameters

        if not self.draws or self.job == "calibrate":
            return ()
        return uncertain_parameters(self.base_scenario().plant_model, tuple(self.uncertainty))

    # ---------------------------------------------------------------- identity
    def definition(self) -> dict:
        """The study as JSON-able data: what :attr:`digest` hashes and ``study.json`` keeps."""
        # the axes in their order: it decides which grid point each run number is
        job = {"job": self.job, "options": self.options} if self.job != "simulate" else {}
        return {"base": self.base, "grid": [[k, list(v)] for k, v in self.axes],
                "uncertainty": {k: list(v) for k, v in self.uncertainty.items()}, "draws": self.draws,
                "seed": self.seed, "combine": self.combine, **job, "pkmlab": __version__}

    @property
    def digest(self) -> str:
        """SHA-256 of :meth:`definition`: equal for studies that compute the same runs."""
        text = json.dumps(self.definition(), sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()

    def __hash__(self) -> int:
        return hash(self.digest)

    def __eq__(self, other) -> bool:
        return isinstance(other, Study) and self.digest == other.digest and self.name == other.name


def study_from_dict(data: dict, source: str = "<study>") -> Study:
    """The :class:`Study` of a study file's parsed tables (the module docstring's format)."""
    if not isinstance(data, dict):
        raise FileFormatError(f"{source}: a study must be a TOML document of tables, got {shown(data)}")
    for key in data:
        if key not in STUDY_TABLES:
            raise FileFormatError(f"{source}: unknown table '{key}'{suggestion(str(key), STUDY_TABLES)}")
        if not isinstance(data[key], dict):
            raise FileFormatError(f"{source}: [{key}] must be a table, got {shown(data[key])}")
    head = data.get("study", {})
    for key in head:
        if key not in STUDY_KEYS:
            raise FileFormatError(f"{source}: unknown key '{key}' in [study]{suggestion(str(key), STUDY_KEYS)}")
    if ("base" in head) == ("base" in data):
        raise FileFormatError(f"{source}: give the base scenario once: [study].base = \"FILE.toml\" or [base.*] "
                              "tables")
    if "base" in head:
        if not isinstance(head["base"], str) or not head["base"]:
            raise FileFormatError(f"{source}: [study].base must be a scenario file name, got {shown(head['base'])}")
        base = Path(source).parent / head["base"]
    else:
        base = data["base"]  # inline tables: a mechanism file they name is relative to the study file
    name = head.get("name", Path(source).stem or "study")
    if not isinstance(name, str) or not name:
        raise FileFormatError(f"{source}: [study].name must be a non-empty string, got {shown(name)}")
    job = head.get("job", _STUDY_DEFAULTS["job"])
    for table in TABLE.values():
        if table in data and TABLE.get(job) != table:
            raise FileFormatError(f"{source}: [{table}] is the options of job = "
                                  f"\"{next(j for j, t in TABLE.items() if t == table)}\", not of job = {shown(job)}")
    options = data.get(TABLE[job], {}) if isinstance(job, str) and job in TABLE else {}
    head = {**_STUDY_DEFAULTS, **head}
    return Study.create(base, data.get("grid", {}), data.get("uncertainty", {}), head["draws"], head["seed"], name,
                        source, head["combine"], job, options)


def load_study(path) -> Study:
    """Read a study file (format: this module's docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The study file (TOML).

    Returns
    -------
    Study
        The checked study, ready for :func:`~pkmlab.sweep`.

    Raises
    ------
    FileFormatError
        If the file cannot be read, is malformed TOML, or does not follow the format.
    InvalidParameterError
        If ``path`` is not a file name, or a value is refused (the message names the file and the key).

    Examples
    --------
    >>> import pathlib
    >>> import tempfile
    >>> import pkmlab
    >>> from pkmlab.formats.scenario import SCENARIO_DIR
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> lines = ["[study]", f"base = '{(SCENARIO_DIR / 'fast.toml').as_posix()}'", "[grid]",
    ...          '"controller.kp" = [500.0, 1000.0]']
    >>> _ = (folder / "kp.toml").write_text(chr(10).join(lines))
    >>> study = pkmlab.load_study(folder / "kp.toml")
    >>> study.name, study.size
    ('kp', 2)
    >>> import shutil
    >>> shutil.rmtree(folder)
    """
    if not isinstance(path, str) and not hasattr(path, "__fspath__"):
        raise InvalidParameterError(f"path must be a file name (a str or a pathlib.Path), got {type(path).__name__} "
                                    f"{shown(path, 50)}")
    return study_from_dict(read_toml(path), str(path))

