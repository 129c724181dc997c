"""Errors raised by pkmlab.

Every error a user can cause by their input derives from :class:`PkmlabError`; its message
is one line that names the problem (which parameter, which leg, which pose). The CLI prints
that line and exits non-zero instead of showing a traceback.
"""

from __future__ import annotations


class PkmlabError(Exception):
    """Base class of the errors caused by a user's input."""


class InvalidParameterError(PkmlabError, ValueError):
    """An architecture or option value that is impossible (non-finite, non-positive, ...)."""


class FileFormatError(PkmlabError, ValueError):
    """A file that cannot be read or does not follow the documented format."""


class UnstableControlError(InvalidParameterError):
    """Controller gains and a sample time that make the sampled-data closed loop unstable: refused
    before running (spectral-radius check), or a run whose tracking error diverged."""


class UnreachablePoseError(PkmlabError, ValueError):
    """A platform pose that one or more legs cannot reach (inverse kinematics).

    ``legs`` lists the 1-based numbers of the legs that cannot reach; ``index`` is the position
    of the first offending pose in a batch (``None`` for a single pose).
    """

    def __init__(self, message: str, legs: tuple[int, ...] = (), index: tuple[int, ...] | None = None):
        super().__init__(message)
        self.legs = legs
        self.index = index


class SingularityError(PkmlabError, RuntimeError):
    """A configuration at or too near a gain-type (forward) singularity, ``det(Jηφ) = 0``."""


class BranchFollowingError(SingularityError):
    """The assembly mode cannot be followed continuously to the requested actuated angles."""


class AssemblyError(PkmlabError, ValueError):
    """Actuated angles for which the mechanism cannot be assembled (no forward solution)."""


class IncompleteSolutionWarning(UserWarning):
    """A general method found solutions but cannot guarantee that it found all of them (e.g. forward
    kinematics near a double root): the message says where."""


class PkmlabDeprecationWarning(FutureWarning):
    """An input pkmlab still reads but will stop reading (a ``[manipulator]`` table, ...): the message says
    what to write instead. A FutureWarning, so that Python shows it by default."""


def shown(value, limit: int = 80) -> str:
    """``repr(value)`` on one line, shortened: whatever a user passes, the message stays one line."""
    try:
        text = " ".join(repr(value).split())
    except Exception:  # a repr that fails (an int of more than 4300 digits...)
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."
