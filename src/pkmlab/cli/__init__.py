"""The ``pkmlab`` command line: a thin layer over the library.

Exit codes: 0 success; 1 a problem with the input (unreachable pose, invalid parameter,
unreadable file, ...), reported as one line on stderr (or as ``{"error": ...}`` on stdout
with ``--json``); 2 a malformed command line; 130 interrupted.

The grammar is :mod:`._parser`'s; each command lives in the module of its family (:mod:`.kinematics`,
:mod:`.dynamics`, :mod:`.maps`, :mod:`.simulate`, :mod:`.reproduce`, :mod:`.animate`, :mod:`.view`,
:mod:`.mujoco`, :mod:`.study`), imported when it runs; what they share is in :mod:`._common`.
"""

import sys

# (no `from __future__ import annotations` here: its import, the first of a process, would be a moment outside the
# try below; this module's annotations are all valid as they are)
try:  # Ctrl-C while the command line itself loads (its own imports): a quiet exit, as anywhere later
    import signal  # (its import takes milliseconds: here, not in entry() before its handler is installed)

    from ..errors import InvalidParameterError, PkmlabError
    from ._common import deprecated, notes, print_error, print_json
    from ._common import strict_json as _strict_json  # noqa: F401 (its former name here, kept importable)
    from ._parser import build_parser
except BaseException as exc:  # (a Ctrl-C inside a class's creation comes out as a RuntimeError caused by it)
    cause = exc
    while cause is not None and not isinstance(cause, KeyboardInterrupt):
        cause = cause.__cause__ or cause.__context__
    if cause is None:
        raise
    print("pkmlab: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

__all__ = ["build_parser", "entry", "main"]


def _pose_names(args) -> tuple[str, ...]:
    """The names of the pose's coordinates of the machine on the command line (the paper's 3-RRR's by default;
    a description that cannot be read yet names none: its error comes later, on its own)."""
    mechanism = getattr(args, "mechanism", None)
    if not mechanism:
        return ("x", "y", "alpha")  # the paper's 3-RRR (the default machine, and that of --params)
    try:
        from ..description.files import load_mechanism
        from ..description.presets import PRESETS, preset

        return (preset(mechanism) if mechanism in PRESETS else load_mechanism(mechanism)).pose_names
    except PkmlabError:
        return ()


def _check_finite(args) -> None:
    """Every number of the command line must be finite: NaN or infinity is refused naming its argument
    (for a list of positional numbers, the one at fault: ``alpha``, ``theta1``...; an option by the spelling
    typed)."""
    import math

    actions = {a.dest: a for a in args.parser._actions}
    for dest, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        bad = [k for k, v in enumerate(values) if isinstance(v, float) and not math.isfinite(v)]
        if not bad:
            continue
        action = actions.get(dest)
        if dest == "theta" and action is not None and not action.option_strings:
            name = f"theta{bad[0] + 1}"
        elif dest == "pose" and action is not None and not action.option_strings:
            names = _pose_names(args)
            name = names[bad[0]] if bad[0] < len(names) else "POSE"
        elif action is not None and action.option_strings:
            name = getattr(args, f"{dest}_flag", None) or action.option_strings[0]
        else:
            name = dest
        raise InvalidParameterError(f"{name} must be finite, got {' '.join(str(v) for v in values)}")


def _check_mode(args) -> None:
    """``--mode`` as signs (``+ - +``, ``1 -1 1``, ``+1 -1 +1``) or one word (``+-+``), the spellings the Python
    API takes, read as a tuple of ±1; how many signs the machine needs is checked by the command, which knows
    the machine. Anything but signs is refused naming the option."""
    tokens = getattr(args, "mode", None)
    if tokens is None:
        return
    text = "".join(tokens).replace("+1", "+").replace("-1", "-").replace("1", "+")
    if not text or text.strip("+-"):
        raise InvalidParameterError(f"--mode: a working mode is signs such as + - + (or one word such as +-+), "
                                    f"got {' '.join(tokens)}")
    args.mode = tuple(1 if c == "+" else -1 for c in text)


def _quiet_stdout() -> None:
    """After a closed pipe (`pkmlab fk ... | head -1`), send what is left of stdout nowhere, so that
    Python's final flush does not report the broken pipe again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


def _with_notes(args):
    """Run the command; what pkmlab's general methods warn of (an assembly mode that may be missing) is
    said as one note line each, a deprecated input (a scenario's ``[manipulator]`` table) as a note once the
    command has succeeded. Another library's warning (NumPy's "overflow encountered in multiply" on a gain of
    1e300...) is no reason a user can act on: dropped when the command fails with its own one-line error (which
    gives the true reason), one note line (:func:`library_note`) when it succeeds."""
    import warnings

    from ..errors import IncompleteSolutionWarning, PkmlabDeprecationWarning

    caught: list = []
    refused = False
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", IncompleteSolutionWarning)
            warnings.simplefilter("always", PkmlabDeprecationWarning)
            return args.func(args)
    except PkmlabError:
        refused = True
        raise
    finally:  # said also when the command then fails, once the recording has stopped
        said: set[str] = set()
        for w in caught:
            if issubclass(w.category, IncompleteSolutionWarning):
                notes(args)(str(w.message))
            elif issubclass(w.category, PkmlabDeprecationWarning):
                deprecated(args, str(w.message))
            elif not refused and (note := library_note(w)) not in said:
                said.add(note)
                notes(args)(note)


def library_note(w) -> str:
    """A warning of a library that reached the command (``w``, a ``warnings.WarningMessage``) as one note line in
    pkmlab's words, naming where it arose: the result is pkmlab's, the warning a sign of something to report."""
    import os

    where = os.path.basename(w.filename)
    text = " ".join(str(w.message).split())
    return f"a computation warned on the way ({w.category.__name__} at {where}:{w.lineno}: {text}); please report it"


#: The one-shot commands: one evaluation at a single pose or state, whose kernels are quicker to run interpreted
#: than to load compiled (:mod:`pkmlab._compile_cache`), for every machine.
ONE_SHOT = ("ik", "fk", "dynamics")


def _interpreted(args) -> bool:
    """Whether the command is a one-shot evaluation (:data:`ONE_SHOT`): ``ik``, ``fk`` or ``dynamics`` of any
    machine."""
    return args.command in ONE_SHOT


def _run(argv: list[str] | None, one_shot_interpreted: bool = False) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    import os

    interpreted_here = (one_shot_interpreted and _interpreted(args) and "pkmlab._compile_cache" not in sys.modules
                        and "PKMLAB_INTERPRETED" not in os.environ)  # the user's choice kept
    if interpreted_here:
        os.environ["PKMLAB_INTERPRETED"] = "1"  # read when the first kernel module is imported
    try:
        return _command(args)
    finally:
        if interpreted_here:  # not passed on to anything this process starts
            os.environ.pop("PKMLAB_INTERPRETED", None)


def _command(args) -> int:
    try:
        _check_finite(args)
        _check_mode(args)
        result = _with_notes(args)
    except PkmlabError as exc:
        print_error(args, exc)
        return 1
    except KeyboardInterrupt as exc:  # a study's says what it kept and how to finish
        print(f"pkmlab {args.command}: interrupted" + (f": {exc}" if str(exc) else ""), file=sys.stderr)
        return 130
    for message in getattr(args, "deprecations", ()):  # once the work is done: an error stays one line
        notes(args)(message)
    if getattr(args, "json", False):
        print_json(result)
    sys.stdout.flush()
    return 0


def main(argv: list[str] | None = None, one_shot_interpreted: bool = False) -> int:
    """The ``pkmlab`` command. Exit codes: 0 success, 1 a problem with the input (one line on stderr),
    2 a malformed command line, 130 interrupted (Ctrl-C, at any moment, start-up included), 141 the
    reader of the output went away (a closed pipe, as ``| head``), quietly.

    ``one_shot_interpreted`` (the executable's choice, :func:`entry`): in a process that has not loaded any
    kernel yet, the one-shot commands (``ik`` ...) run their kernels interpreted: the same code, without
    the 0.4 s of importing Numba and loading compiled kernels.

    Parameters
    ----------
    argv : list of str, optional
        The command line's arguments after ``pkmlab`` (default ``sys.argv[1:]``).
    one_shot_interpreted : bool
        Run a one-shot command's kernels interpreted, when none is loaded yet.

    Returns
    -------
    int
        The exit code. A pkmlab error (an unreachable pose, an invalid parameter, an unreadable file...) is
        reported as one line on stderr, or as ``{"error": ...}`` on stdout with ``--json``, and gives 1.

    Raises
    ------
    SystemExit
        From the parser, for a malformed command line (code 2) or ``--help`` and ``--version`` (code 0).

    Examples
    --------
    >>> from pkmlab.cli import main
    >>> main(["ik", "0.2", "0.21", "0", "--mode", "+-+"])
    inverse kinematics of the paper (3-R*RR) at x = 0.2, y = 0.21, alpha = 0
         mode     theta1     theta2     theta3       q1_2       q2_2       q3_2          S
    (+, -, +)  +1.614598  +1.983105  -1.184617  -0.472346  -2.804508  +2.751289  -0.744577
    0
    >>> main(["ik", "5", "0.21", "0"])  # out of reach: the reason is one line on stderr
    1
    """
    try:
        return _run(argv, one_shot_interpreted)
    except KeyboardInterrupt:
        print("pkmlab: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        _quiet_stdout()
        return 141
    except Exception:
        # a Ctrl-C inside an extension module's initialisation comes out as another error (NumPy's import
        # turns it into an ImportError): the interrupt it was, when the executable's handler saw one
        if _INTERRUPTED:
            print("pkmlab: interrupted", file=sys.stderr)
            return 130
        raise


#: Set by the executable's Ctrl-C handler (:func:`entry`): an interrupt arrived.
_INTERRUPTED = False


def _on_interrupt(_signum, _frame):
    global _INTERRUPTED
    _INTERRUPTED = True
    raise KeyboardInterrupt


def _interrupt_from_callbacks(hook=sys.unraisablehook):
    """``sys.unraisablehook`` that turns a Ctrl-C caught inside a callback from compiled code (Numba's
    LLVM engine calls back into Python while it compiles; an exception there cannot propagate and would
    be printed as "Exception ignored", then lost) into a Ctrl-C delivered again to the main program, and
    that keeps quiet, once interrupted, about the finalisers of what the interrupt left half-built."""
    def interrupt(*_args):
        raise KeyboardInterrupt

    def unraisable(info):
        if isinstance(info.exc_value, KeyboardInterrupt) and hasattr(signal, "setitimer"):
            # raised here it would be caught again: deliver it a moment later, once out of the callback
            signal.signal(signal.SIGALRM, interrupt)
            signal.setitimer(signal.ITIMER_REAL, 0.005)
        elif not _INTERRUPTED:
            hook(info)
        # else: an object the interrupt left half-built (an LLVM pass builder whose constructor it cut short)
        # fails in its finaliser; that is the interrupt's doing, already reported in one line

    return unraisable


def entry() -> int:
    """The ``pkmlab`` executable: :func:`main` with Ctrl-C honoured everywhere, even inside callbacks of
    compiled code; ignored only once the work is done and the interpreter shuts down (its exit handlers
    would otherwise print a traceback, and there is nothing left to interrupt)."""
    code, interrupted = None, False
    # The handler raises at whichever instruction runs next: main()'s first one (before its own try), and those
    # after it returned, are this function's to handle, up to the moment Ctrl-C is ignored again
    try:
        signal.signal(signal.SIGINT, _on_interrupt)
        sys.unraisablehook = _interrupt_from_callbacks()
        code = main(one_shot_interpreted=True)
    except KeyboardInterrupt:
        interrupted = True
    finally:  # (also on the way out of --help, a malformed command line, an error)
        while True:  # an interrupt landing while Ctrl-C is being ignored: ignore it again
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                if hasattr(signal, "setitimer"):
                    signal.setitimer(signal.ITIMER_REAL, 0)  # a Ctrl-C still to be delivered again: cancelled
                break
            except KeyboardInterrupt:
                interrupted = True
    if code is None and interrupted:  # (after main returned, its own exit code: its work is done)
        print("pkmlab: interrupted", file=sys.stderr)
        code = 130
    return code

