"""The generated kernels of spatial structures against the plain statement of the chain conventions
(:func:`pkmlab.description.spatial.leg_frames`), finite differences and the file on disk."""

from __future__ import annotations

import dataclasses
import functools
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from pkmlab.codegen import provenance, spatial
from pkmlab.description.files import load_mechanism
from pkmlab.description.presets import SPATIAL_PRESETS, preset
from pkmlab.description.spatial import attachment_point, full_poses, leg_frames, orientation
from pkmlab.model.mechanism_model import MechanismModel, _evaluate, bind, constraint_residual

NAMES = sorted(SPATIAL_PRESETS)
MECHANISMS = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
#: The kernels' checks run on the presets and on a structure of two types of legs, whose kernels loop over each
#: type apart: a 3-RPS whose third leg is a 3-PRS's (its kernels only: such a platform cannot be assembled).
MODELS = [*NAMES, "mixed"]


@functools.cache
def _model(name: str) -> MechanismModel:
    if name != "mixed":
        return MechanismModel.from_preset(name)
    rps, prs = load_mechanism(MECHANISMS / "3rps.toml"), load_mechanism(MECHANISMS / "3prs.toml")
    return bind(dataclasses.replace(rps, name="3-RPS with a PRS leg", legs=(*rps.legs[:2], prs.legs[2])))


@pytest.mark.parametrize("name", NAMES)
def test_generated_file_is_current(name):
    """The committed module is the derivation's text: by ``make derive``'s record of its inputs and text while
    neither has changed (the planar machines' modules are derived again in every run,
    ``test_generated_kinematics``), else by deriving it again — and then the record is stale: a source of the
    derivation changed since ``make derive`` (each run would derive again, 20 s for the Stewart platform)."""
    m = preset(name)
    path = spatial.generated_path(m)
    committed = path.read_text()
    if f"Derived with SymPy {sp.__version__}." not in committed:
        pytest.skip("another SymPy: the numeric checks below still hold")
    if not provenance.recorded_current(path):
        assert committed == spatial.generate_source(m), "run `make derive` to regenerate the kernels"
        pytest.fail("the kernels are current but their record is not: run `make derive` to record them")


def test_the_derivation_record_is_of_the_derivations_inputs_and_text(tmp_path, monkeypatch):
    """A module is recorded current only with the inputs and the text ``make derive`` recorded: an edited module
    or an edited source of the derivation is not."""
    package = tmp_path / "pkmlab"
    package.mkdir()
    for entry in provenance.INPUTS:  # a copy of the derivation's sources
        source = provenance.PACKAGE / entry
        (shutil.copytree if source.is_dir() else shutil.copy2)(source, package / entry)
    monkeypatch.setattr(provenance, "PACKAGE", package)
    monkeypatch.setattr(provenance, "RECORD", package / "kernels" / "provenance.json")
    module = package / "kernels" / "spatial_x.py"
    module.parent.mkdir()
    module.write_text("A = 1\n")
    assert not provenance.recorded_current(module)  # no record
    provenance.record({module.name: module.read_text()})
    assert provenance.recorded_current(module)
    module.write_text("A = 2\n")
    assert not provenance.recorded_current(module)  # edited by hand
    module.write_text("A = 1\n")
    assert provenance.recorded_current(module)
    with (package / "description" / "spatial.py").open("a") as f:
        f.write("\n# an edit\n")
    assert not provenance.recorded_current(module)  # a source of the derivation edited


def _legs(m, q):
    n, passive, out = len(m.legs), iter(q[len(m.legs):len(q) - len(m.platform.q_pose_names)]), []
    for i, leg in enumerate(m.legs):
        coords = []
        for j in leg.joints[:-1]:
            coords += [q[i]] if j.actuated else [next(passive) for _ in range(j.coordinates)]
        out.append(coords)
    assert n == len(out)
    return out


@pytest.mark.parametrize("name", MODELS)
def test_constraints_and_body_positions_are_the_described_chains(name):
    model = _model(name)
    m, k = model.description, model.kernels
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, k.N_COORDINATES)
        eta = constraint_residual(model, q)
        coms = _evaluate(model, k.body_poses, (k.N_BODIES, 3), q)
        b = 0
        for i, (leg, coords) in enumerate(zip(m.legs, _legs(m, q), strict=True)):
            frames = leg_frames(leg, coords)
            end = frames[-1][0]
            pose = full_poses(m, q[len(q) - k.N_POSE:])
            np.testing.assert_allclose(eta[3 * i:3 * i + 3], end - attachment_point(m, i, pose), atol=1e-12)
            for (origin, rot), body in zip(frames, leg.bodies, strict=False):
                np.testing.assert_allclose(coms[b], origin + rot @ np.array(body.com), atol=1e-12)
                b += 1


def _body_rotations(m, q):
    """Every body's orientation, the legs' (from the chain conventions) then the platform's (``Rz Ry Rx``)."""
    out = []
    for leg, coords in zip(m.legs, _legs(m, q), strict=True):
        out += [rot for _origin, rot in leg_frames(leg, coords)[:-1]]
    pose = full_poses(m, q[len(q) - len(m.platform.q_pose_names):])
    return [*out, orientation(*pose[3:6]) if m.platform.kind == "rigid" else np.eye(3)]


@pytest.mark.parametrize("name", MODELS)
def test_body_jacobians_against_finite_differences(name):
    """Linear rows: the mass centres' derivatives; angular rows: ω in the body frame, from Rᵀ Ṙ."""
    model = _model(name)
    m, k = model.description, model.kernels
    rng = np.random.default_rng(8)
    h = 1e-6
    for _ in range(5):
        q, q_dot = rng.uniform(-np.pi, np.pi, k.N_COORDINATES), rng.normal(size=k.N_COORDINATES)
        J = _evaluate(model, k.body_jacobians, (k.N_BODIES, 6, k.N_COORDINATES), q)
        bias = _evaluate(model, k.body_bias, (k.N_BODIES, 6), q, q_dot)
        com = _evaluate(model, k.body_poses, (k.N_BODIES, 3), q + h * q_dot)
        com -= _evaluate(model, k.body_poses, (k.N_BODIES, 3), q - h * q_dot)
        np.testing.assert_allclose(J[:, :3] @ q_dot, com / (2 * h), atol=1e-7)
        plus, minus, here = _body_rotations(m, q + h * q_dot), _body_rotations(m, q - h * q_dot), _body_rotations(m, q)
        for b, (rp, rm, r) in enumerate(zip(plus, minus, here, strict=True)):
            w = r.T @ (rp - rm) / (2 * h)
            np.testing.assert_allclose(J[b, 3:] @ q_dot, [w[2, 1], w[0, 2], w[1, 0]], atol=1e-7)
        # the bias is the acceleration at q̈ = 0: d/dt (J q̇) along q̇
        jp = _evaluate(model, k.body_jacobians, (k.N_BODIES, 6, k.N_COORDINATES), q + h * q_dot)
        jm = _evaluate(model, k.body_jacobians, (k.N_BODIES, 6, k.N_COORDINATES), q - h * q_dot)
        np.testing.assert_allclose(bias, (jp - jm) @ q_dot / (2 * h), atol=1e-6)


@pytest.mark.parametrize("name", MODELS)
def test_the_jacobians_non_zeros_are_the_dense_jacobians_entries(name):
    """``body_jacobian_values`` at ``(JB_BODY, JB_ROW, JB_COL)`` is ``body_jacobians``, which is 0 elsewhere: each
    leg's non-zeros found at its offset ``LEG_JB`` (legs of two types in the mixed structure)."""
    model = _model(name)
    k = model.kernels
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, k.N_COORDINATES)
        dense = _evaluate(model, k.body_jacobians, (k.N_BODIES, 6, k.N_COORDINATES), q)
        values = _evaluate(model, k.body_jacobian_values, (k.N_JB,), q)
        np.testing.assert_array_equal(values, dense[k.JB_BODY, k.JB_ROW, k.JB_COL])
        dense[k.JB_BODY, k.JB_ROW, k.JB_COL] = 0.0
        assert not dense.any()


@pytest.mark.parametrize("name", MODELS)
def test_constraint_jacobian_and_bias_against_finite_differences(name):
    model = _model(name)
    k = model.kernels
    rng = np.random.default_rng(12)
    h = 1e-6
    for _ in range(5):
        q, q_dot = rng.uniform(-np.pi, np.pi, k.N_COORDINATES), rng.normal(size=k.N_COORDINATES)
        jac = _evaluate(model, k.constraint_jacobian, (k.N_CONSTRAINTS, k.N_COORDINATES), q)
        fd = np.column_stack([(constraint_residual(model, q + h * e) - constraint_residual(model, q - h * e)) / (2 * h)
                              for e in np.eye(k.N_COORDINATES)])
        np.testing.assert_allclose(jac, fd, atol=1e-7)
        bias = _evaluate(model, k.constraint_bias, (k.N_CONSTRAINTS,), q, q_dot)
        jp = _evaluate(model, k.constraint_jacobian, (k.N_CONSTRAINTS, k.N_COORDINATES), q + h * q_dot)
        jm = _evaluate(model, k.constraint_jacobian, (k.N_CONSTRAINTS, k.N_COORDINATES), q - h * q_dot)
        np.testing.assert_allclose(bias, (jp - jm) @ q_dot / (2 * h), atol=1e-6)
