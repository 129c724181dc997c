"""What the commands share: the machine of ``--mechanism`` or ``--params``, counts of numbers, tables,
output paths written whole or not at all, progress and notes on stderr, and JSON on stdout."""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import InvalidParameterError, PkmlabError

#: Below this |S| (a run's default singularity guard) a command's configuration is reported with a warning.
NEAR_SINGULAR_S = 1e-2
#: The machine of the commands that take ``--mechanism`` when it is not given.
DEFAULT_MECHANISM = "paper"

#: What ``--params`` says when it is used: how to give the same machine the way every machine is given (a
#: command without ``--mechanism``, as ``reproduce``, says where the machine goes instead).
PARAMS_DEPRECATED = ("--params (a parameter file of the paper's 3-RRR) is deprecated and will be removed: write the "
                     "machine as a description file (pkmlab help parameter-files converts a parameter file) and "
                     "give it with {instead}")
PARAMS_INSTEAD = "--mechanism FILE.toml"
PARAMS_INSTEAD_SIMULATE = "pkmlab simulate SCENARIO.toml --mechanism FILE.toml, which runs a scenario on it"


def deprecated(args, message: str) -> None:
    """Say ``message`` (a deprecated option was used) as a note on stderr once the command has succeeded: a
    command that fails says its error, in one line, and nothing else."""
    said = getattr(args, "deprecations", None)
    if said is None:
        said = args.deprecations = []
    if message not in said:
        said.append(message)


def params_file(args):
    """``--params`` (deprecated, said when the command has succeeded), or None."""
    path = getattr(args, "params", None)
    if path:
        takes_mechanism = any("--mechanism" in a.option_strings for a in args.parser._actions)
        deprecated(args, PARAMS_DEPRECATED.format(instead=PARAMS_INSTEAD if takes_mechanism else
                                                  PARAMS_INSTEAD_SIMULATE))
    return path


def warn_near_singularity(command: str, where: str, s: float, consequence: str) -> str | None:
    """The warning for a configuration with ``|S| < NEAR_SINGULAR_S``, said on stderr as
    ``pkmlab COMMAND: warning: WHERE is near a gain-type singularity (|S| = ... < 0.01): CONSEQUENCE``;
    None (and nothing said) farther from it."""
    from .._format import apart

    if abs(s) >= NEAR_SINGULAR_S:
        return None
    value, limit = apart(abs(s), NEAR_SINGULAR_S)
    warning = f"near a gain-type singularity (|S| = {value} < {limit}): {consequence}"
    print(f"pkmlab {command}: warning: {where} is {warning}", file=sys.stderr)
    return warning


def signs(mode) -> str:
    """A working mode as the tables show it: ``(+, -, +)``."""
    return "(" + ", ".join("+" if m > 0 else "-" for m in mode) + ")"


def table(header: list[str], rows: list[list]) -> str:
    """Right-aligned columns, floats with six decimals and a sign."""
    cells = [header] + [[f"{v:+.6f}" if isinstance(v, float) else str(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells)


def model_of(args):
    """The machine of the command (:class:`~pkmlab.model.mechanism_model.MechanismModel`, one type for every machine):
    ``--mechanism``, a preset name or a description file (``[mechanism]`` table), the paper's 3-RRR when not
    given; or the 3-RRR of the deprecated ``--params`` file (with an explicit ``--mechanism``, refused)."""
    from ..description.files import load_mechanism
    from ..description.presets import PRESETS
    from ..model.mechanism_model import MechanismModel

    name = getattr(args, "mechanism", None)
    if getattr(args, "params", None):
        if name is not None:
            raise InvalidParameterError("--params describes the paper's 3-RRR; with --mechanism, give a description "
                                        "file instead")
        from ..formats.params import load_manipulator
        from ..paper.geometry import Planar3RRR

        manipulator = load_manipulator(params_file(args))
        if manipulator != Planar3RRR.paper():
            return MechanismModel.from_description(manipulator.to_mechanism())
        name = DEFAULT_MECHANISM  # the paper's own parameters: the paper, to the last bit
    else:
        name = DEFAULT_MECHANISM if name is None else name
    if name in PRESETS:
        return MechanismModel.from_preset(name)
    if not Path(name).suffix:
        raise InvalidParameterError(f"--mechanism {name}: not a preset ({', '.join(PRESETS)}) nor a .toml file")
    return MechanismModel.from_description(load_mechanism(name))


def mechanism_name(args, model) -> str:
    """The machine as the JSON names it: its description's name (a preset's is the preset's), or the file of
    the deprecated ``--params``."""
    return str(args.params) if getattr(args, "params", None) else model.name


def working_mode(args, model):
    """``--mode`` (already read as signs, ``args.mode``) checked against the machine: None when not given, else
    one of its working modes as a tuple of ints. A wrong number of signs is a malformed command line (usage,
    exit code 2), as a wrong number of pose values is."""
    from ..model.mechanism_model import working_modes

    if getattr(args, "mode", None) is None:
        return None
    modes = [tuple(int(s) for s in m) for m in working_modes(model)]
    k = len(modes[0])
    if len(args.mode) != k:
        if k == 0:
            args.parser.error(f"argument --mode: the {model.name} ({model.description.notation}) has one working "
                              f"mode: no --mode, got {signs(args.mode)}")
        args.parser.error(f"argument --mode: {k} signs for the {model.name} ({model.description.notation}), such as "
                          f"{' '.join('+' * k)} or {'+' * k}; got {len(args.mode)}")
    mode = tuple(args.mode)
    if mode not in modes:
        raise InvalidParameterError(f"--mode must be one of {', '.join(signs(m) for m in modes)} for a "
                                    f"{model.description.notation}, got {signs(mode)}")
    return mode


def pose_gap(pose, other, names) -> float:
    """How far apart two poses are, metres and radians together (angles the short way round), as
    ``--near`` measures it."""
    import math

    angles = {"alpha", "roll", "pitch", "yaw"}
    return math.hypot(*[math.remainder(a - b, 2 * math.pi) if name in angles else a - b
                        for a, b, name in zip(pose, other, names, strict=True)])


def shown(values) -> str:
    """Numbers as the messages show them: ``0.2 0.21 0``."""
    return " ".join(f"{v:g}" for v in values)


def check_count(args, values, n: int, what: str) -> None:
    """As many numbers as the machine needs, or a malformed command line (usage, exit code 2)."""
    if len(values) != n:
        args.parser.error(f"{what}: {n} numbers for this machine, got {len(values)}")


def status_messages(args):
    """Progress messages on stderr, only for a person watching: not with --json, --quiet or a pipe."""
    if args.json or args.quiet or not sys.stderr.isatty():
        return None
    return lambda msg: print(msg, file=sys.stderr)


MAX_RESOLUTION = 2001


def progress_bar(args, total: int, label: str):
    """A progress bar on stderr; silent with --quiet or when stderr is not a terminal."""
    from ..progress import Progress

    return Progress(total, label, enabled=not args.quiet)


def check_resolution(value: int) -> int:
    if not 2 <= value <= MAX_RESOLUTION:
        raise InvalidParameterError(f"--resolution must be between 2 and {MAX_RESOLUTION} grid points per axis, "
                                    f"got {value}")
    return value


def figure_suffixes() -> set[str]:
    from matplotlib.backend_bases import FigureCanvasBase

    return {"." + ext for ext in FigureCanvasBase.get_supported_filetypes()} - {".raw", ".rgba"}


def output_path(path, flag: str, suffixes: set[str] | None = None, force: bool = False) -> Path:
    """``path`` as a ``Path``, refused before any computation when it cannot be written, or when it is a file
    pkmlab did not write (or that changed since it did) and ``force`` is not given."""
    import os

    from ..outputs import written_by_pkmlab

    out = Path(path)
    if out.is_dir():
        raise PkmlabError(f"cannot write {out}: it is a folder")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        shown = ", ".join(sorted(suffixes)) if len(suffixes) <= 4 else ", ".join(sorted(suffixes)[:6]) + ", ..."
        what = f"'{out.suffix}'" if out.suffix else "no suffix"
        raise PkmlabError(f"{flag} {out}: unsupported file type ({what}); use {shown}")
    parent = out.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise PkmlabError(f"cannot write {out}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PkmlabError(f"cannot write {out}: {parent} is not writable")
    if not force and (out.exists() or out.is_symlink()) and not written_by_pkmlab(out):
        raise PkmlabError(f"{flag} {out}: the file exists and pkmlab did not write it (or it changed since): give "
                          "another name, or add --force to replace it")
    return out


class NewFolders:
    """Remembers which parent folders of ``paths`` do not exist yet; if the ``with`` block fails,
    removes those of them that were created (and are still empty), so an error leaves nothing."""

    def __init__(self, *paths: Path):
        self.missing: list[Path] = []
        for path in paths:
            parent = path.parent
            while not parent.exists() and parent not in self.missing:
                self.missing.append(parent)
                parent = parent.parent

    def __enter__(self) -> NewFolders:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            for folder in sorted(self.missing, key=lambda f: len(f.parts), reverse=True):
                try:
                    folder.rmdir()
                except OSError:
                    pass


class Staged:
    """Temporary files beside ``paths``, moved into place together when the ``with`` block succeeds.

    On any error (or Ctrl-C) the temporary files, and the folders made for them, are removed and no
    output file is touched.
    """

    def __init__(self, *paths: Path):
        self.paths = paths
        self.temps: list[Path] = []
        self.folders = NewFolders(*paths)

    def __enter__(self) -> list[Path]:
        import os
        import tempfile

        try:
            for path in self.paths:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
                os.close(fd)
                self.temps.append(Path(tmp))
        except OSError as exc:
            self._clean(failed=True)
            raise PkmlabError(f"cannot write {path}: {exc.strerror or exc}") from None
        return self.temps

    def __exit__(self, exc_type, exc, tb) -> None:
        import os

        from ..outputs import mark_written

        failed = exc_type is not None
        try:
            if exc_type is None:
                umask = os.umask(0)
                os.umask(umask)
                for tmp, path in zip(self.temps, self.paths, strict=True):
                    try:
                        os.chmod(tmp, 0o666 & ~umask)
                        os.replace(tmp, path)
                        mark_written(path)
                    except OSError as err:
                        failed = True
                        raise PkmlabError(f"cannot write {path}: {err.strerror or err}") from None
            elif issubclass(exc_type, OSError):
                raise PkmlabError(f"cannot write {', '.join(map(str, self.paths))}: {exc.strerror or exc}") from None
        finally:
            self._clean(failed)

    def _clean(self, failed: bool) -> None:
        for tmp in self.temps:
            tmp.unlink(missing_ok=True)
        if failed:
            self.folders.__exit__(RuntimeError, None, None)


def save_figure(fig, out: Path) -> None:
    """Write ``fig`` to ``out`` whole or not at all, and close it."""
    import matplotlib.pyplot as plt

    try:
        with Staged(out) as temps:
            fig.savefig(temps[0], dpi=150)
    finally:
        plt.close(fig)


def loop_closures(args, option: str, value: str | None, deprecated: str, deprecated_given: bool) -> str:
    """The loop closures ``option`` asks for: ``stiff`` (the default) or ``soft``, anything else refused in one
    line. ``deprecated``, the old flag for stiff closures (now the default), does nothing but say so on stderr."""
    closures = "stiff" if value is None else value
    if closures not in ("stiff", "soft"):
        raise InvalidParameterError(f"{option} must be stiff or soft, got {value!r}")
    if deprecated_given:
        if closures == "soft":
            raise InvalidParameterError(f"{deprecated} (stiff closures) contradicts {option} soft: give {option} only")
        print(f"pkmlab {args.command}: note: {deprecated} is deprecated and does nothing: stiff loop closures are "
              f"now the default ({option} soft for MuJoCo's own)", file=sys.stderr)
    return closures


def notes(args):
    """What a command says besides its result (an earlier result replaced, ...): one line on stderr,
    ``pkmlab CMD: note: ...``; nothing with --quiet."""

    def say(message: str) -> None:
        if not getattr(args, "quiet", False):
            print(f"pkmlab {args.command}: note: {message}", file=sys.stderr)

    return say


def strict_json(value):
    """``value`` for ``json.dumps(allow_nan=False)``: non-finite numbers (which strict JSON parsers
    reject) become ``null``."""
    import math

    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def print_json(value) -> None:
    """A command's result on stdout, strict JSON (no NaN), indented."""
    import json

    print(json.dumps(strict_json(value), indent=2, allow_nan=False))


def print_error(args, exc: Exception) -> None:
    """A command's error: ``{"error": {"type", "message"}}`` on stdout with ``--json``, else one line on stderr."""
    import json

    if getattr(args, "json", False):
        print(json.dumps({"error": {"type": type(exc).__name__, "message": str(exc)}}))
    else:
        print(f"pkmlab {args.command}: error: {exc}", file=sys.stderr)
