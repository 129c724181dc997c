"""Errors raised by pkmlab.

Every error a user can cause by their input derives from :class:`PkmlabError`; its message
is one line that names the problem (which parameter, which leg, which pose). The CLI prints
that line and exits non-zero instead of showing a traceback.
"""

from __future__ import annotations


class PkmlabError(Exception):
    """Base class of the errors caused by a user's input.

    Its message is one line that names the problem (which parameter, which leg, which pose); catch it to handle
    every error pkmlab raises on purpose.

    Examples
    --------
    >>> import pkmlab
    >>> try:
    ...     pkmlab.load("no_such_machine")
    ... except pkmlab.PkmlabError as exc:
    ...     print(type(exc).__name__)
    InvalidParameterError
    """


class InvalidParameterError(PkmlabError, ValueError):
    """An architecture or option value that is impossible (non-finite, non-positive, of the wrong shape, ...).

    Also a :class:`ValueError`.

    Examples
    --------
    >>> import pkmlab
    >>> pkmlab.inverse_kinematics(pkmlab.load("paper"), [0.2, 0.21])
    Traceback (most recent call last):
    ...
    pkmlab.errors.InvalidParameterError: pose must have 3 components (shape (..., 3)), got shape (2,)
    """


class FileFormatError(PkmlabError, ValueError):
    """A file that cannot be read or does not follow the documented format."""


class UnstableControlError(InvalidParameterError):
    """Controller gains and a sample time that make the sampled-data closed loop unstable.

    Refused before running (spectral-radius check), or a run whose tracking error diverged. A subclass of
    :class:`InvalidParameterError`.

    Examples
    --------
    >>> import pkmlab
    >>> stiff = pkmlab.paper_scenario("fast").replace(controller=pkmlab.ControllerSpec(kp=1e7))
    >>> pkmlab.simulate(stiff)
    Traceback (most recent call last):
    ...
    pkmlab.errors.UnstableControlError: the sampled-data loop is unstable: computed torque with kp = 1e+07, ...
    """


class UnreachablePoseError(PkmlabError, ValueError):
    """A platform pose that one or more legs cannot reach (inverse kinematics).

    Also a :class:`ValueError`.

    Parameters
    ----------
    message : str
        The one-line message.
    legs : tuple of int
        The 1-based numbers of the legs that cannot reach (attribute ``legs``).
    index : tuple of int or None
        The position of the first offending pose in a batch, ``None`` for a single pose (attribute ``index``).

    Examples
    --------
    >>> import pkmlab
    >>> try:
    ...     pkmlab.inverse_kinematics(pkmlab.load("paper"), [[0.2, 0.21, 0.0], [2.0, 2.0, 0.0]], mode="+-+")
    ... except pkmlab.UnreachablePoseError as exc:
    ...     print(exc.legs, exc.index)
    (1,) (1,)
    """

    def __init__(self, message: str, legs: tuple[int, ...] = (), index: tuple[int, ...] | None = None):
        super().__init__(message)
        self.legs = legs
        self.index = index


class SingularityError(PkmlabError, RuntimeError):
    """A configuration at or too near a gain-type (forward) singularity, ``det(Jηφ) = 0``.

    Also a :class:`RuntimeError`.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("3rpr")
    >>> q = pkmlab.inverse_kinematics(model, [0.26, 0.15, 0.0], mode=()).q
    >>> pkmlab.actuator_space_model(model, q, [0.0, 0.0, 0.0])
    Traceback (most recent call last):
    ...
    pkmlab.errors.SingularityError: q is at a gain-type singularity (|S| = ... < 1e-06): the actuator-space model ...
    """


class BranchFollowingError(SingularityError):
    """The assembly mode cannot be followed continuously to the requested actuator values.

    A subclass of :class:`SingularityError`: raised by :func:`~pkmlab.branch_following`,
    :func:`~pkmlab.follow_path` (with attributes ``row`` and ``reason``) and a run that nears a singularity.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.2, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> try:
    ...     pkmlab.follow_path(model, q, [q[:3], q[:3] + [0.2, 0.0, 0.0]])
    ... except pkmlab.BranchFollowingError as exc:
    ...     print(exc.row, exc.reason)
    1 a jump of 0.2, more than max_step = 0.05
    """


class AssemblyError(PkmlabError, ValueError):
    """Actuator values for which the mechanism cannot be assembled (no forward solution).

    Also a :class:`ValueError`.

    Examples
    --------
    A plant whose links are 20 % shorter than the controller's model cannot reach the actuator values the run
    starts at:

    >>> import pkmlab
    >>> from pkmlab.description.mechanism import scaled_mechanism
    >>> model = pkmlab.load("paper")
    >>> plant = pkmlab.MechanismModel.from_description(scaled_mechanism(model.description, length=0.8))
    >>> pkmlab.simulate(pkmlab.paper_scenario("nominal").replace(plant=plant))
    Traceback (most recent call last):
    ...
    pkmlab.errors.AssemblyError: the plant cannot be assembled at the start actuators [0.189012, 3.112031, -2.642405]
    """


class IncompleteSolutionWarning(UserWarning):
    """A general method found solutions but cannot guarantee that it found all of them.

    For example forward kinematics near a double root: the message says where.

    Examples
    --------
    A warning, so that the solutions found are still returned; where an incomplete answer must stop the work,
    make it an error:

    >>> import warnings
    >>> import pkmlab
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("error", pkmlab.IncompleteSolutionWarning)
    ...     len(pkmlab.forward_kinematics(pkmlab.load("paper"), [1.0, 2.0, -2.0]).q)
    2
    """


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
