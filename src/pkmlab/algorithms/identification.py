"""Dynamic identification of any described mechanism: its base parameters (:mod:`~pkmlab.algorithms.regressor`)
estimated from measured actuators and efforts, with the standard deviation of each.

From a log to states (:func:`filter_measurements`). A machine logs its actuators ``θ`` and efforts ``τ`` at a
fixed rate; the rates and accelerations are not measured. Each actuator's ``θ`` is smoothed and differentiated
by a Savitzky–Golay filter — a least-squares polynomial of order ``polyorder`` over a sliding window of
``window`` seconds, its value and first two derivatives at the window's centre — and the efforts are smoothed
by the same filter, so that both sides of ``τ = Y(q, θ̇, θ̈) π`` see the same bandwidth and delay ("parallel
filtering"). The passive joints and the pose follow from the smoothed ``θ`` by branch following
(:func:`~pkmlab.algorithms.kinematics.follow_path`), from the assembly mode the log starts in. Filtered
samples are then kept one in ``d`` (decimation): the filter passes frequencies up to about
``(polyorder + 1) / (3.2 M - 4.6)`` of the Nyquist frequency, ``M`` its half-width in samples (Schafer, "What
is a Savitzky–Golay filter?", 2011), so keeping one sample in ``d = (3.2 M - 4.6) / (polyorder + 1)`` leaves
noise that is nearly white from sample to sample — which the standard deviations of the estimate assume (without
it they come out about four times too small, measured).

Estimation (:func:`identify`). With ``W`` the base regressor stacked over the samples and ``y`` the efforts,
ordinary least squares first gives each actuator's effort-error standard deviation ``σ_j`` from its
residuals; every row of actuator ``j`` is then weighted by ``1/σ_j`` and the weighted system solved again
(weighted least squares, as Gautier and Khalil identify serial robots). The covariance of the estimate is
``s² (WᵀW)⁻¹`` of the weighted system (``s²`` its residual variance), whose diagonal gives each base
parameter's ``σ``; its relative ``σ`` (per cent of the estimate) says how well the data determine it. A base
parameter the data do not excite is refused by name rather than given an arbitrary value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_batch, as_broadcast, as_choice, as_count, as_flag, as_real
from ..errors import BranchFollowingError, InvalidParameterError, shown
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from .kinematics import as_model, follow_path, forward_kinematics
from .regressor import BaseParameters, base_parameters, dynamics_regressor, parameter_names

__all__ = ["Measurements", "Identification", "sampling_step", "decimation", "filter_measurements", "identify",
           "scaled_condition_number"]

#: The default width (s) of the Savitzky–Golay window of :func:`filter_measurements`.
DEFAULT_WINDOW = 0.05
#: The default order of its polynomial: a 4th-order fit keeps the acceleration of a smooth motion unbiased
#: over the window while averaging the measurement noise.
DEFAULT_POLYORDER = 4
#: A sampling step farther than this share from the median step is refused: the filter needs a fixed rate.
UNIFORM_TOL = 1e-3
#: A scaled condition number above this means that some base parameter is not excited by the data.
UNEXCITED = 1e10


# ------------------------------------------------------------------ from a log to states
@dataclass(frozen=True)
class Measurements:
    """A log filtered into states (:func:`filter_measurements`), all smoothed by the same filter.

    Attributes
    ----------
    t : ndarray, shape (N,)
        The kept sample times (s).
    q : ndarray, shape (N, n)
        The configurations, by branch following (rad or m per entry).
    theta_dot : ndarray, shape (N, n_actuators)
        The actuator rates (rad/s or m/s).
    theta_ddot : ndarray, shape (N, n_actuators)
        The actuator accelerations (rad/s² or m/s²).
    tau : ndarray, shape (N, n_actuators)
        The efforts (N·m or N).

    Examples
    --------
    >>> import pkmlab
    >>> run = pkmlab.simulate(pkmlab.paper_scenario("fast"))
    >>> log = pkmlab.filter_measurements(run.scenario.model, run.t, run.theta, run.tau, q_start=run.q[0])
    >>> log.q.shape, [a.shape for a in log.states[1:]]
    ((31, 9), [(31, 3), (31, 3)])
    """

    t: np.ndarray
    q: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    tau: np.ndarray

    @property
    def states(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, theta_dot, theta_ddot)``, the states :func:`identify` takes."""
        return self.q, self.theta_dot, self.theta_ddot


def sampling_step(t: np.ndarray, first_row: int = 0) -> float:
    """The fixed step of the times ``t`` (N,), refusing a time that does not increase or a rate that is not fixed,
    by row (numbered from ``first_row``).

    The step is the median of the differences; each may depart from it by ``UNIFORM_TOL`` of it.

    Parameters
    ----------
    t : ndarray, shape (N,)
        The sample times (s).
    first_row : int
        The number of the first sample in messages (1 for a log file's first data row).

    Returns
    -------
    float
        The sampling step (s).

    Raises
    ------
    InvalidParameterError
        Naming the first row whose time is not after the row before it, or whose step departs from the others.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.algorithms.identification import sampling_step
    >>> sampling_step(np.arange(5) * 0.01)
    0.01
    >>> sampling_step(np.array([0.0, 0.01, 0.01]), first_row=1)
    Traceback (most recent call last):
        ...
    pkmlab.errors.InvalidParameterError: t at row 3 (0.01 s) is not after the row before it (0.01 s): time must increase
    """
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0]) + 1
        raise InvalidParameterError(f"t at row {k + first_row} ({t[k]:g} s) is not after the row before it "
                                    f"({t[k - 1]:g} s): time must increase")
    step = float(np.median(dt))
    off = np.abs(dt - step) > UNIFORM_TOL * step
    if off.any():
        k = int(np.flatnonzero(off)[0]) + 1
        raise InvalidParameterError(f"t at row {k + first_row}: a step of {dt[k - 1]:.6g} s against the log's "
                                    f"{step:.6g} s; the filter needs a fixed sampling rate (resample the log)")
    return step


def _window_samples(window: float, step: float, polyorder: int, count: int) -> int:
    """The window in samples: odd, longer than the polynomial's order, no longer than the log. A window shorter
    than the polynomial needs is refused: it would fit the samples, not filter them (and is most often a log whose
    time is not in seconds)."""
    length = int(round(window / step))
    length += 1 - length % 2
    if length < polyorder + 2:
        raise InvalidParameterError(f"the filter's window of {window:g} s spans {window / step:.3g} samples at the "
                                    f"log's step of {step:.6g} s, and a polynomial of order {polyorder} needs "
                                    f"{polyorder + 3 - polyorder % 2}: is t in seconds? (else a longer window)")
    if length > count:
        raise InvalidParameterError(f"too few samples: {count} rows, and the filter's window of {window:g} s needs "
                                    f"{length} at the log's step of {step:.6g} s")
    return length


def _rest_rate(thetas: np.ndarray, smoothed) -> np.ndarray:
    """The largest rate (n,) the differentiating filter ``smoothed`` gives readings ``thetas`` (N, n) would show
    held constant, by its round-off alone: the filter's rate of constant readings of each actuator's largest
    magnitude, and at least its coefficients' round-off bound (it grows with the window and the polynomial's order)."""
    level = np.abs(thetas).max(axis=0)
    constant = np.abs(smoothed(np.ones((len(thetas), 1)) * level, 1)).max(axis=0)
    impulse = np.zeros((len(thetas), 1))
    impulse[len(thetas) // 2] = 1.0
    bound = np.finfo(float).eps * level * np.abs(smoothed(impulse, 1)).sum()  # ε |θ| Σ|c|
    return np.maximum(constant, bound)


def _reversal_rows(rates: np.ndarray, length: int, rest: np.ndarray) -> np.ndarray:
    """The rows (N,) whose Savitzky–Golay window of ``length`` samples (the whole first or last window at the log's
    ends, as ``mode="interp"`` fits them) holds a reversal of any column of ``rates`` (N, n) — a change of its sign,
    or a rate within ``rest`` (n,) of zero (at rest, where friction holds whatever it must) —, a sample either side
    of it included (the true reversal lies between two samples of the filtered rate)."""
    count, half = len(rates), length // 2
    signs = np.where(np.abs(rates) <= rest, 0.0, np.sign(rates))
    # at row k or between k and k + 1 (a rest at the last row is a change from the row before, or a rest there)
    reversal = np.any((signs[1:] != signs[:-1]) | (signs[:-1] == 0), axis=1)
    before = np.concatenate([[0], np.cumsum(reversal)])  # reversals between rows below j: before[j]
    lo = np.clip(np.arange(count) - half, 0, count - length)
    first, last = np.maximum(lo - 1, 0), np.minimum(lo + length, count - 1)  # reversal indices k in [first, last)
    return before[last] > before[first]


def _start_configuration(model: MechanismModel, theta0: np.ndarray, pose, mode) -> np.ndarray:
    """The assembly mode the log starts in: the one nearest ``pose`` (the pose logged at the first row) when
    given, else the one nearest a well-conditioned configuration of working ``mode``."""
    modes = forward_kinematics(model, theta0)
    if modes.count == 0:
        raise InvalidParameterError(f"theta at row 0 {np.round(theta0, 6).tolist()}: the machine cannot be assembled "
                                    "there (out of reach, or not this machine's actuator values and units)")
    qs = modes.q[:modes.count]
    if pose is not None:
        pose, _ = as_batch("pose", pose, model.description.dof, single=True)
        gap = np.linalg.norm(mm.pose_of(model, qs) - pose[0], axis=1)
    else:
        mode = mm.working_modes(model)[0] if mode is None else mode
        gap = np.linalg.norm(qs - mm.well_conditioned_configuration(model, tuple(mode)), axis=1)
    return qs[int(np.argmin(gap))]


def decimation(length: int, polyorder: int) -> int:
    """One sample in how many to keep after a Savitzky–Golay filter of ``length`` samples and order
    ``polyorder``: the ratio of the Nyquist frequency to the filter's cut-off (Schafer 2011).

    Parameters
    ----------
    length : int
        The filter's window (samples, odd).
    polyorder : int
        The order of its polynomial.

    Returns
    -------
    int
        The decimation factor, at least 1.

    Examples
    --------
    >>> from pkmlab.algorithms.identification import decimation
    >>> decimation(51, 4), decimation(5, 4)
    (15, 1)
    """
    half = (length - 1) / 2
    return max(1, int(round((3.2 * half - 4.6) / (polyorder + 1))))


def filter_measurements(model, t, theta, tau, *, window: float = DEFAULT_WINDOW,
                        polyorder: int = DEFAULT_POLYORDER, decimate="auto", q_start=None, pose=None,
                        mode=None, first_row: int = 0, efforts: str = "held", reversals: str = "drop") -> Measurements:
    """States from a log of measured actuators and efforts at a fixed rate.

    Savitzky–Golay smoothing and differentiation of ``theta``, the same smoothing of ``tau`` (parallel
    filtering), and the configurations by branch following.

    Parameters
    ----------
    model : MechanismModel
        The machine the log is of (:func:`pkmlab.load`).
    t : array_like, shape (N,)
        The sample times (s), increasing at a fixed rate.
    theta : array_like, shape (N, n_actuators)
        The measured actuator values (rad, or m for a prismatic actuator).
    tau : array_like, shape (N, n_actuators)
        The measured efforts (N·m, or N).
    window : float
        The filter's window (s): longer averages more noise, shorter follows faster motion.
    polyorder : int
        The order of the filter's polynomial (at least 2: the acceleration is its second derivative).
    decimate : int or "auto"
        Keep one filtered sample in this many; ``"auto"`` (default) the filter's bandwidth ratio
        (:func:`decimation`), 1 keeps every sample.
    q_start : array_like, shape (n,), optional
        The configuration at the first row (the assembly mode to follow). Default: the assembly mode nearest
        ``pose`` if given, else nearest a well-conditioned configuration of working ``mode``.
    pose : array_like, shape (dof,), optional
        The pose logged at the first row (to choose the assembly mode).
    mode : tuple of int, optional
        The working mode whose well-conditioned configuration chooses the assembly mode (default the first).
    first_row : int
        The number of the first sample in messages (1 for a log file's first data row).
    efforts : {"held", "sampled"}
        How the logged efforts act. ``"held"`` (default): each one from its sample to the next (a zero-order
        hold: the effort a controller commands, ``tau`` of ``pkmlab simulate``), so that the mean effort over
        the half-samples either side of row ``k`` is ``(τ_{k-1} + τ_k) / 2`` — fitting ``τ_k`` itself to the
        state at ``t_k`` would be half a sample late, a bias of order ``h`` on every estimate (0.8 % of the
        largest base parameter of a five-bar at 1 kHz, measured). ``"sampled"``: an instantaneous
        measurement at the sample's time.
    reversals : {"drop", "keep"}
        ``"drop"`` (default): leave out the rows whose filter window holds a reversal of any actuator's rate (a
        change of sign of its filtered rate). There the smoothed effort mixes the Coulomb friction of both
        directions of motion, which no friction law of the smoothed rate represents: kept, such rows bias the
        drives' friction estimates (on the paper's machine logged by a 20-bit encoder, measured: the Coulomb
        friction 3–9 % low, the viscous 2–4 % high). A row goes when its window, widened by a sample either side,
        holds a change of sign of a rate; the rows of a machine at rest go too (a rate within a hundred times the
        filter's round-off of zero, or the wiggles of its readings' noise). ``"keep"``: every decimated row (a
        machine without friction loses nothing by them).

    Returns
    -------
    Measurements
        The kept samples.

    Raises
    ------
    InvalidParameterError
        Naming the row where time does not increase or the rate changes, too few samples for the window, or no
        row left away from the rates' reversals.
    BranchFollowingError
        Naming the first row the machine cannot reach from the one before it.

    Examples
    --------
    >>> import pkmlab
    >>> run = pkmlab.simulate(pkmlab.paper_scenario("fast"))
    >>> log = filter_measurements(run.scenario.model, run.t, run.theta, run.tau, q_start=run.q[0])
    >>> run.t.size, log.t.size
    (787, 31)
    """
    from scipy.signal import savgol_filter

    from .kinematics import as_working_mode

    model = as_model(model)
    na = model.n_actuators
    thetas, _ = as_batch("theta", theta, na)
    ts = as_batch("t", t, len(thetas), single=True)[0][0]  # one time per row of theta
    taus, _ = as_batch("tau", tau, na)
    if len(taus) != len(thetas):
        raise InvalidParameterError(f"tau must have as many rows as theta ({len(thetas)}), got {len(taus)}")
    window = as_real("window", window, "positive")
    polyorder = as_count("polyorder", polyorder, 2, 10)
    if not (isinstance(decimate, str) and decimate == "auto"):
        decimate = as_count("decimate", decimate, 1)
    if mode is not None:
        mode = as_working_mode(model, mode, "mode")
    first_row = as_count("first_row", first_row, 0)
    efforts = as_choice("efforts", efforts, ("held", "sampled"))
    reversals = as_choice("reversals", reversals, ("drop", "keep"))
    if len(ts) < 2:
        raise InvalidParameterError(f"too few samples: {len(ts)} rows")
    step = sampling_step(ts, first_row)
    length = _window_samples(window, step, polyorder, len(ts))
    keep = np.arange(0, len(ts), decimation(length, polyorder) if decimate == "auto" else decimate)

    def smoothed(x, deriv=0):
        return savgol_filter(x, length, polyorder, deriv=deriv, delta=step, axis=0, mode="interp")

    if efforts == "held" and len(taus) > 1:  # the row before the first is unknown: the first stands for it
        taus = np.concatenate([taus[:1], 0.5 * (taus[1:] + taus[:-1])])
    theta_s = smoothed(thetas)
    if q_start is None:
        q_start = _start_configuration(model, theta_s[0], pose, mode)
    try:
        q = follow_path(model, q_start, theta_s)
    except BranchFollowingError as exc:
        raise BranchFollowingError(f"the log leaves the machine's reach: theta at row {exc.row + first_row} "
                                   f"{np.round(thetas[exc.row], 6).tolist()} cannot be reached from the row before it:"
                                   f" {exc.reason}") from None
    rates = smoothed(thetas, 1)
    if reversals == "drop":
        # at rest: a rate within a hundred times what the filter's round-off gives readings that never change
        keep = keep[~_reversal_rows(rates, length, 100.0 * _rest_rate(thetas, smoothed))[keep]]
        if keep.size == 0:
            raise InvalidParameterError(f"every row's filter window of {window:g} s holds a reversal of an actuator's "
                                        "rate (or the machine is at rest): log a longer motion, or keep those rows "
                                        "(reversals='keep', pkmlab identify --reversals keep) where the machine has "
                                        "no friction to identify")
    return Measurements(ts[keep], q[keep], rates[keep], smoothed(thetas, 2)[keep], smoothed(taus)[keep])


# ------------------------------------------------------------------ estimation
def scaled_condition_number(W) -> float:
    """The condition number of an observation matrix ``W`` (rows, r) with its columns scaled to unit length:
    independent of the parameters' units, it measures how well the data separate them (1 is best).

    Parameters
    ----------
    W : array_like, shape (rows, r)
        The observation matrix (its columns in any units).

    Returns
    -------
    float
        The ratio of the largest to the smallest singular value of the scaled matrix (dimensionless, at least 1);
        infinite when a column is zero or the scaled matrix has a zero singular value.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.algorithms.identification import scaled_condition_number
    >>> scaled_condition_number([[1.0, 0.0], [0.0, 1e-3]])  # orthogonal columns, whatever their units
    1.0
    >>> round(scaled_condition_number(np.array([[1.0, 1.0], [0.0, 1e-3]])), 1)  # nearly parallel columns
    2000.0
    >>> scaled_condition_number([[1.0, 0.0], [2.0, 0.0]])
    inf
    """
    W = np.asarray(W, dtype=float)
    norms = np.linalg.norm(W, axis=0)
    if not np.all(norms > 0):
        return float("inf")
    s = np.linalg.svd(W / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


@dataclass(frozen=True)
class Identification:
    """The base parameters estimated from data (:func:`identify`).

    Attributes
    ----------
    base : BaseParameters
        What was estimated: ``base.names[i]`` is the combination ``estimate[i]`` is the value of.
    estimate : ndarray, shape (r,)
        The weighted-least-squares estimate of the base parameters (kg, kg·m, kg·m², by combination).
    sigma : ndarray, shape (r,)
        Its standard deviations (same units).
    effort_sigma : ndarray, shape (n_actuators,)
        Each actuator's effort-error standard deviation (N·m or N), from its residuals (the rows' weights were
        ``1/σ_j``).
    residual : ndarray, shape (N, n_actuators)
        The measured efforts less those the estimate predicts (N·m or N).
    condition_number : float
        :func:`scaled_condition_number` of the weighted observation matrix.
    covariance : ndarray, shape (r, r)
        The estimate's covariance (``sigma`` is the root of its diagonal).
    coulomb_rate : float
        The drives' Coulomb friction model the estimate is for (:func:`~pkmlab.algorithms.regressor.coulomb_shape`).

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q, theta_dot, theta_ddot = pkmlab.random_states(model, 50)
    >>> tau = pkmlab.inverse_dynamics(model, q, theta_dot, theta_ddot)
    >>> result = pkmlab.identify(model, q, theta_dot, theta_ddot, tau)
    >>> result.names[1], result.drives, list(result.summary())[:3]
    ('body1_2.my', False, ['base_parameters', 'condition_number', 'samples'])
    """

    base: BaseParameters
    estimate: np.ndarray
    sigma: np.ndarray
    effort_sigma: np.ndarray
    residual: np.ndarray
    condition_number: float
    covariance: np.ndarray | None = None
    coulomb_rate: float = 0.0

    @property
    def names(self) -> tuple[str, ...]:
        """The base parameters' names (:attr:`BaseParameters.names`)."""
        return self.base.names

    @property
    def relative_sigma(self) -> np.ndarray:
        """``100 σ / |estimate|`` (per cent); infinite for an estimate of zero."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.estimate != 0, 100.0 * self.sigma / np.abs(self.estimate), np.inf)

    @property
    def drives(self) -> bool:
        """Whether the drives' parameters were estimated too."""
        return any(name.startswith("drive") for name in self.base.parameters)

    def predict(self, model, q, theta_dot, theta_ddot) -> np.ndarray:
        """The efforts that the estimate predicts at the states given (e.g. a held-out run).

        Parameters
        ----------
        model : MechanismModel
            The machine the estimate is of.
        q : array_like, shape (..., n)
            Configurations on the loop closures (rad or m per entry).
        theta_dot, theta_ddot : array_like, shape (..., n_actuators)
            The actuator rates (rad/s or m/s) and accelerations (rad/s² or m/s²).

        Returns
        -------
        ndarray, shape (..., n_actuators)
            The efforts (N·m or N).
        """
        Y = dynamics_regressor(model, q, theta_dot, theta_ddot, drives=self.drives, coulomb_rate=self.coulomb_rate)
        return self.base.regressor(Y) @ self.estimate

    def summary(self) -> dict:
        """The estimate as plain data.

        Returns
        -------
        dict
            ``base_parameters`` (one record per base parameter: ``name``, ``estimate``, ``sigma``,
            ``relative_sigma_percent``), ``condition_number``, ``samples``, ``effort_sigma`` and ``rms_residual``
            (one per actuator, N·m or N), ``unidentifiable``.
        """
        rows = [{"name": n, "estimate": float(e), "sigma": float(s), "relative_sigma_percent": float(r)}
                for n, e, s, r in zip(self.names, self.estimate, self.sigma, self.relative_sigma, strict=True)]
        return {"base_parameters": rows, "condition_number": self.condition_number,
                "samples": int(self.residual.shape[0]), "effort_sigma": self.effort_sigma.tolist(),
                "rms_residual": np.sqrt(np.mean(self.residual**2, axis=0)).tolist(),
                "unidentifiable": list(self.base.unidentifiable)}


def _least_squares(W: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.linalg.lstsq(W, y, rcond=None)[0]


def _check_excitation(W: np.ndarray, names: tuple[str, ...]) -> None:
    """Refuse data that leave a base parameter undetermined, naming the one least determined."""
    norms = np.linalg.norm(W, axis=0)
    if not np.all(norms > 0):
        j = int(np.flatnonzero(~(norms > 0))[0])
        raise InvalidParameterError(f"the data do not excite base parameter {names[j]!r} at all: a motion that moves "
                                    "it is needed (e.g. pkmlab's excitation trajectories)")
    _, s, vt = np.linalg.svd(W / norms, full_matrices=False)
    if not s[-1] > s[0] / UNEXCITED:
        j = int(np.argmax(np.abs(vt[-1])))
        raise InvalidParameterError(f"the data do not determine base parameter {names[j]!r} (condition number "
                                    f"{s[0] / max(s[-1], 1e-300):.3g}): a richer motion is needed")


def identify(model, q, theta_dot, theta_ddot, tau, *, drives: bool = False, coulomb_rate: float = 0.0,
             base=None) -> Identification:
    """The base parameters of ``model`` estimated from states and measured efforts by weighted least squares.

    Parameters
    ----------
    model : MechanismModel
        The machine whose geometry the data come from (its inertial parameters are not used).
    q : array_like, shape (N, n)
        Configurations on the loop closures (rad or m per entry).
    theta_dot, theta_ddot : array_like, shape (N, n_actuators)
        The actuators' rates (rad/s or m/s) and accelerations (rad/s² or m/s²; from a log:
        :func:`filter_measurements`).
    tau : array_like, shape (N, n_actuators)
        The measured efforts (N·m or N).
    drives : bool
        Estimate the drives' armature, viscous and Coulomb friction too.
    coulomb_rate : float
        With ``drives``: the Coulomb friction model ``fc tanh(θ̇ / coulomb_rate)``, or ``fc sign(θ̇)`` for 0
        (default). The model the controller will compensate with; the two differ most near rest, where a
        sign fitted to a smooth friction (or the reverse) biases every estimate.
    base : BaseParameters, optional
        The base parameters to estimate (default :func:`~pkmlab.algorithms.regressor.base_parameters` of
        ``model``).

    Returns
    -------
    Identification
        The estimate, its standard deviations and covariance, the residuals and the condition number.

    Raises
    ------
    InvalidParameterError
        With fewer equations than base parameters, data that leave one undetermined (named), ``base`` not the
        base parameters of ``model`` (with ``drives`` as given), or states that are refused (off the loop
        closures, shapes that do not broadcast).
    SingularityError
        If a state is at a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q, theta_dot, theta_ddot = pkmlab.random_states(model, 50)
    >>> tau = pkmlab.inverse_dynamics(model, q, theta_dot, theta_ddot)
    >>> result = identify(model, q, theta_dot, theta_ddot, tau)
    >>> truth = result.base.of(pkmlab.inertial_parameters(model))
    >>> bool(np.allclose(result.estimate, truth))
    True
    """
    model = as_model(model)
    drives = as_flag("drives", drives)
    coulomb_rate = as_real("coulomb_rate", coulomb_rate, "non-negative")
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, theta_ddots, taus, _ = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na),
                                                        ("theta_ddot", theta_ddot, na), ("tau", tau, na))
    if base is None:
        base = base_parameters(model, drives=drives)
    elif not isinstance(base, BaseParameters) or base.parameters != parameter_names(model, drives):
        raise InvalidParameterError(f"base must be the base parameters of this model{' with drives' if drives else ''}"
                                    f" (pkmlab.base_parameters(model{', drives=True' if drives else ''})), got "
                                    f"{shown(base, 60)}")
    count, r = len(qs), base.rank
    if count * na < r:
        raise InvalidParameterError(f"too few samples: {count} × {na} efforts for {r} base parameters")
    Yb = base.regressor(dynamics_regressor(model, qs, theta_dots, theta_ddots, drives=drives,
                                           coulomb_rate=coulomb_rate))  # (N, n, r)
    W = np.swapaxes(Yb, 0, 1).reshape(na * count, r)  # actuator by actuator
    y = taus.T.reshape(-1)
    _check_excitation(W, base.names)
    dof = max(count * na - r, 1)
    first = (y - W @ _least_squares(W, y)).reshape(na, count)
    effort_sigma = np.sqrt(np.sum(first**2, axis=1) / (dof / na))
    floor = max(effort_sigma.max(), 1e-300) * 1e-9  # noise-free data: every actuator weighted alike
    weights = 1.0 / np.maximum(effort_sigma, floor)
    Ww, yw = W * np.repeat(weights, count)[:, None], y * np.repeat(weights, count)
    estimate = _least_squares(Ww, yw)
    residual_w = yw - Ww @ estimate
    s2 = float(residual_w @ residual_w) / dof
    covariance = s2 * np.linalg.inv(Ww.T @ Ww)
    residual = (y - W @ estimate).reshape(na, count).T
    return Identification(base, estimate, np.sqrt(np.clip(np.diag(covariance), 0.0, None)), effort_sigma, residual,
                          scaled_condition_number(Ww), covariance, coulomb_rate)
