"""Kinematics generated from mechanism descriptions: current with a fresh derivation, and right —
against the plain chain of the description (an independent evaluation) and finite differences."""

import importlib
import math

import numpy as np
import pytest
import sympy as sp

from pkmlab.codegen import planar
from pkmlab.description.mechanism import attachment_point, leg_chain
from pkmlab.description.presets import PLANAR_PRESETS, preset

NAMES = sorted(PLANAR_PRESETS)


def kernels(name):
    return importlib.import_module(f"pkmlab.kernels.{planar.generated_path(preset(name)).stem}")


def packed(m):
    """The packed parameters, read-only as the model hands them to the kernels (mechanism_model.bind): the
    same numbers, and the kernels compiled for the library's calls serve these checks too (a writable array
    would compile every kernel a second time, for the same code)."""
    P = planar.pack(m)
    P.setflags(write=False)
    return P


def trig(k, q):
    """The trig table the kernels read: (cos, sin) of every angle coordinate."""
    sc = np.zeros((len(q), 2))
    k.trig(q, sc)
    return sc


def random_q(rng, name):
    m = preset(name)
    q = rng.uniform(-math.pi, math.pi, len(planar.coordinate_names(m)))
    q[-m.dof:][:2] = rng.uniform(0.0, 0.4, 2)  # a pose near the machine
    for i, leg in enumerate(m.legs):  # slides within their strokes
        if leg.joints[leg.actuated].kind == "P":
            q[i] = rng.uniform(*leg.stroke)
    return q


def leg_coordinates(m, q):
    """Split q into each leg's joint coordinates (joint order), from the documented layout."""
    n, passive, out = len(m.legs), iter(q[len(m.legs):len(q) - m.dof]), []
    for i, leg in enumerate(m.legs):
        out.append([q[i] if j.actuated else next(passive) for j in leg.joints[:-1]])
    assert n == len(out)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_generated_file_is_current(name):
    m = preset(name)
    committed = planar.generated_path(m).read_text()
    if f"Derived with SymPy {sp.__version__}." not in committed:
        pytest.skip("another SymPy: the numeric checks below still hold")
    assert committed == planar.generate_source(m), "run `make derive` to regenerate the kernels"


@pytest.mark.parametrize("name", NAMES)
def test_constraints_and_body_poses_are_the_described_chains(name):
    m, k = preset(name), kernels(name)
    P = packed(m)
    assert k.PARAMETERS == planar.parameter_names(m) and len(P) == len(k.PARAMETERS)
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = random_q(rng, name)
        pose = q[-m.dof:]
        eta = np.empty(k.N_CONSTRAINTS)
        k.constraints(q, trig(k, q), P, eta)
        poses = np.empty((k.N_BODIES, 3))
        k.body_poses(q, trig(k, q), P, poses)
        b = 0
        for i, (leg, coords) in enumerate(zip(m.legs, leg_coordinates(m, q), strict=True)):
            chain = leg_chain(leg, coords)
            np.testing.assert_allclose(eta[2 * i:2 * i + 2], np.subtract(chain[-1][0], attachment_point(m, i, pose)),
                                       atol=1e-14)
            for (origin, direction), body in zip(chain[:-1], leg.bodies, strict=True):
                c, s = math.cos(direction), math.sin(direction)
                com = (origin[0] + c * body.com[0] - s * body.com[1], origin[1] + s * body.com[0] + c * body.com[1])
                np.testing.assert_allclose(poses[b, :2], com, atol=1e-14)
                turn = (poses[b, 2] - direction) / (2 * math.pi)  # an orientation, defined modulo 2 pi
                assert abs(turn - round(turn)) < 1e-14
                b += 1
        alpha = pose[2] if m.dof == 3 else 0.0
        c, s = math.cos(alpha), math.sin(alpha)
        com = m.platform.com
        np.testing.assert_allclose(poses[b], [pose[0] + c * com[0] - s * com[1], pose[1] + s * com[0] + c * com[1],
                                              alpha], atol=1e-14)


@pytest.mark.parametrize("name", NAMES)
def test_jacobians_and_biases_against_finite_differences(name):
    m, k = preset(name), kernels(name)
    P, nq, h = packed(m), len(planar.coordinate_names(m)), 1e-6
    rng = np.random.default_rng(5)

    def value(fn, shape, q):
        out = np.empty(shape)
        fn(q, trig(k, q), P, out)
        return out

    for _ in range(10):
        q, qd = random_q(rng, name), rng.normal(size=nq)
        for f, jac, bias, shape in ((k.constraints, k.constraint_jacobian, k.constraint_bias, (k.N_CONSTRAINTS,)),
                                    (k.body_poses, k.body_jacobians, k.body_bias, (k.N_BODIES, 3))):
            J = value(jac, (*shape, nq), q)
            fd = np.stack([(value(f, shape, q + h * e) - value(f, shape, q - h * e)) / (2 * h)
                           for e in np.eye(nq)], axis=-1)
            np.testing.assert_allclose(J, fd, atol=1e-8)
            b = np.empty(shape)
            bias(q, trig(k, q), qd, P, b)
            # d/dt (J(q) qd) along q(t) = q + t qd, at t = 0
            fd_b = (value(jac, (*shape, nq), q + h * qd) - value(jac, (*shape, nq), q - h * qd)) @ qd / (2 * h)
            np.testing.assert_allclose(b, fd_b, atol=1e-7)
