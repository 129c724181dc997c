"""The three kinds of singularity of a parallel manipulator, each measured at a configuration.

The loop closures ``η(q) = 0`` bind ``q = (θ, φ, p)``: the actuators, the passive joints, the platform's
pose coordinates (its parasitic ones, then the controlled ones ``x``). Their Jacobian ``∂η/∂q`` has as many
rows as ``q`` has coordinates less the machine's degrees of freedom, and three of its parts can lose rank
(Gosselin and Angeles, "Singularity analysis of closed-loop kinematic chains", IEEE Trans. Robotics and
Automation 6(3), 1990; Zlatanov, Fenton and Benhabib, "Singularity analysis of mechanisms and robots via a
velocity-equation model of the instantaneous kinematics", ICRA 1994):

* **inverse** (serial, type 1): ``∂η/∂(θ, φ, parasitic)``, the legs' motion with the controlled pose held —
  singular where a leg is at the boundary of its reach and two of its working modes meet, and the platform
  cannot move in some direction whatever the actuators do;
* **forward** (parallel, type 2): ``∂η/∂(φ, p)``, the motion with the actuators held — singular where the
  platform can move with the actuators locked, or the actuators cannot hold it: pkmlab's ``S``
  (:func:`~pkmlab.algorithms.kinematics.singularity_measure`, whose sign is kept);
* **constraint**: the whole ``∂η/∂q`` — singular where the loop closures themselves degenerate, the legs'
  constraint wrenches become dependent and the machine gains a motion that neither its actuators nor its
  controlled coordinates see (a 3-UPU whose legs are parallel can tilt; a 3-PRS can turn about the line
  its legs' constraint forces meet). Under a translating platform the closures of legs that end in a
  universal joint include their orientation closures, with the platform's orientation free
  (:func:`~pkmlab.description.mobility.orientation_free_closures`): the translating platform's model holds
  it level, the real machine only while its joints' constraint couples span the rotations (a rigid
  platform's model has its universal joints' orientation rows already).

Each is made dimensionless as ``S`` is: the columns of angles (lever arms, in metres) divided by the
platform's size ``ℓ`` (the mean distance between its attachment points), every row scaled to unit length.
The inverse measure is the determinant of its square block, the constraint measure the volume
``√det(J Jᵀ)`` of the rows; both are at most 1 (Hadamard's inequality), 1 when the rows are orthogonal, and
zero exactly at a singularity of their kind. The constraint measure of a machine of many closures is small
even far from a singularity (it multiplies as many factors as there are closures, 18 for a 3-UPU's): compare
it along a path or a map, not with a fixed threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from .kinematics import _configurations, as_model, check_loop_closure, refuse_actuation_redundancy, singularity_measure


@dataclass(frozen=True)
class Singularities:
    """The three singularity measures at configurations (:func:`singularity_kinds`).

    A measure near zero is near a singularity of its kind; each is dimensionless, and the inverse and constraint
    measures are at most 1 in magnitude (module docstring).

    Attributes
    ----------
    inverse : ndarray, shape (...)
        The inverse (serial, type 1) measure.
    forward : ndarray, shape (...)
        The forward (parallel, type 2) measure: ``S`` (:func:`~pkmlab.singularity_measure`), with its sign.
    constraint : ndarray, shape (...)
        The constraint measure, non-negative.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.25, 0.2, 0.0], (-1, 1, -1)).q
    >>> kinds = pkmlab.singularity_kinds(model, q)
    >>> f"{float(kinds.inverse):.4f} {float(kinds.forward):.4f} {float(kinds.constraint):.4f}", kinds.nearest()
    ('0.6721 1.4141 0.6792', 'inverse')
    """

    inverse: np.ndarray
    forward: np.ndarray
    constraint: np.ndarray

    def nearest(self) -> str:
        """The kind whose measure is smallest in magnitude (over every configuration given).

        Returns
        -------
        {"inverse", "forward", "constraint"}
        """
        kinds = {"inverse": self.inverse, "forward": self.forward, "constraint": self.constraint}
        return min(kinds, key=lambda k: float(np.min(np.abs(kinds[k]))))


def platform_size(model: MechanismModel) -> float:
    """``ℓ``: the mean distance between the platform's attachment points, or the machine's length scale when
    they coincide (a point platform)."""
    from .kinematics import length_scale

    points = np.array(model.description.platform.attachments, dtype=float)
    pairs = [np.linalg.norm(points[i] - points[j]) for i in range(len(points)) for j in range(i)]
    mean = float(np.mean(pairs)) if pairs else 0.0
    return mean if mean > 0 else length_scale(model)


def _unit_rows(jac: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(jac, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(norms[:, None] > 0, jac / np.where(norms > 0, norms, 1.0)[:, None], 0.0)


def _volume(jac: np.ndarray) -> float:
    """``√det(J Jᵀ)`` of unit rows: the product of the diagonal of ``R`` in ``Jᵀ = Q R``."""
    if jac.shape[0] > jac.shape[1]:
        return 0.0
    r = np.linalg.qr(jac.T, mode="r")
    return float(np.prod(np.abs(np.diag(r))))


def _scaled_jacobian(model: MechanismModel, q: np.ndarray, size: float) -> np.ndarray:
    jac = mm.constraint_jacobian(model, q)
    return jac * np.where(np.asarray(model.kernels.ANGLES, dtype=bool), 1.0 / size, 1.0)


def _orientation_free(model: MechanismModel, q: np.ndarray, size: float) -> np.ndarray:
    from ..description.mobility import orientation_free_closures

    m = model.description
    n_pose = len(m.platform.q_pose_names)
    x = np.concatenate([*mm.leg_joint_values(model, q), q[len(q) - n_pose:]])
    jac, angles, _misses = orientation_free_closures(m, x)
    return jac * np.where(angles, 1.0 / size, 1.0)


def singularity_kinds(model: MechanismModel, q) -> Singularities:
    """The inverse, forward and constraint singularity measures (module docstring) at configurations ``q``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closures (rad or m per entry).

    Returns
    -------
    Singularities
        ``inverse``, ``forward``, ``constraint``, each shape (...), dimensionless.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closures (naming its residual) or does not have ``n`` components.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.25, 0.2, 0.0], (-1, 1, -1)).q
    >>> kinds = pkmlab.singularity_kinds(model, q)
    >>> bool(0 < abs(kinds.inverse) <= 1 and 0 < kinds.constraint <= 1)
    True
    >>> bool(kinds.forward == pkmlab.singularity_measure(model, q))  # the forward measure is S
    True
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "the singularity kinds")
    qs, shape = _configurations(model, q)
    check_loop_closure(model, qs, shape)
    m = model.description
    size = platform_size(model)
    pose = set(model.pose_columns)  # the others: θ, φ and the parasitic coordinates
    keep = [c for c in range(len(model.coordinates)) if c not in pose]
    # under a translating platform a universal joint's orientation closures are not the model's rows (a rigid
    # platform's are)
    ends_in_u = getattr(m, "spatial", False) and m.platform.kind == "translating" and any(
        leg.joints[-1].kind == "U" for leg in m.legs)
    inverse, constraint = np.empty(len(qs)), np.empty(len(qs))
    for k, qk in enumerate(qs):
        jac = _scaled_jacobian(model, qk, size)
        inverse[k] = float(np.linalg.det(_unit_rows(jac[:, keep])))
        whole = _orientation_free(model, qk, size) if ends_in_u else jac
        constraint[k] = _volume(_unit_rows(whole))
    forward = np.asarray(singularity_measure(model, qs), dtype=float)
    return Singularities(inverse.reshape(shape), forward.reshape(shape), constraint.reshape(shape))
