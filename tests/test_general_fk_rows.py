"""The general forward kinematics' orientation rows of legs that end in a universal joint under a rigid platform
(:mod:`pkmlab.algorithms.general_fk`), on a 3-UPU whose inner axes are not parallel: the catalogue's wrist with
each platform joint turned by 30° about its leg, which leaves its platform no fixed centre.

Its row has no polynomial form in the old reduction (the joint's second axis turned by the leg, not the platform
joint's first); it has one once the platform joint's first axis is written in the basis the leg's body carries
(``_row_through_sphere``), and without any elimination (every passive angle an unknown). Independent checks: each
polynomial system vanishes at the configurations inverse kinematics gives (the kernels' rows, which the
polynomials were not derived from), and not once the platform is turned off them. Its forward kinematics' whole
solve (128 complex assembly modes, monodromy of about 100 s once per machine) is measured, not run, here.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import pkmlab
from pkmlab.algorithms import general_fk
from pkmlab.description.spatial import full_poses, orientation
from pkmlab.model import mechanism_model as mm

WRIST = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3upu_wrist.toml"


def _turned(axis, vector, angle: float) -> list[float]:
    return [float(v) for v in Rotation.from_rotvec(np.asarray(axis) * angle).apply(vector)]


@pytest.fixture(scope="module")
def twisted(tmp_path_factory):
    """The wrist with each platform joint's two axes turned by 30° about its leg's slide."""
    text = WRIST.read_text().replace('name = "3-UPU wrist"', 'name = "3-UPU twisted"')
    for leg in tomllib.loads(text)["mechanism"]["leg"]:
        base, slide, (a1, a2) = leg["axes"]
        new = [base, slide, [_turned(slide, a1, np.pi / 6), _turned(slide, a2, np.pi / 6)]]
        old = f"axes = {leg['axes']!r}"
        assert old in text
        text = text.replace(old, f"axes = {new!r}")
    path = tmp_path_factory.mktemp("twisted") / "3upu_twisted.toml"
    path.write_text(text)
    return pkmlab.load(path)


def _unknowns(model, q: np.ndarray, names: list[str], R0: np.ndarray) -> dict[str, float]:
    """The polynomial system's unknowns at the configuration ``q``: the pose (the orientation as the Cayley
    parameters about ``R0``) and every passive joint's cosines and sines."""
    m = model.description
    whole = full_poses(m, q[-6:])  # x, y, z, roll, pitch, yaw: q ends with the whole pose
    turn = Rotation.from_matrix(R0.T @ orientation(*whole[3:])).as_rotvec()
    angle = np.linalg.norm(turn)
    g = turn / angle * np.tan(angle / 2.0)
    value = {"X": whole[0], "Y": whole[1], "Z": whole[2], "g1": g[0], "g2": g[1], "g3": g[2]}
    for i, (leg, joints) in enumerate(zip(m.legs, mm.leg_joint_values(model, q), strict=True)):
        at = 0
        for k, joint in enumerate(leg.joints[:-1]):
            own = joints[at:at + joint.coordinates]
            at += joint.coordinates
            if joint.kind == "P":
                value[f"l{i + 1}_{k + 1}"] = own[0]
                continue
            for ab, phi in zip("ab", own, strict=False):
                value[f"c{i + 1}_{k + 1}{ab}"], value[f"s{i + 1}_{k + 1}{ab}"] = np.cos(phi), np.sin(phi)
    return {name: value[name] for name in names}


def _absolute(expression, values: dict) -> float:
    """``expression`` evaluated with every number, unknown and parameter by its size and every sum as the sum of
    its terms' sizes: a bound of the sum of its expanded terms' sizes, the scale its round-off is relative to."""
    if expression.is_Number:
        return abs(float(expression))
    if expression.is_Symbol:
        return abs(values[expression])
    parts = [_absolute(a, values) for a in expression.args]
    if expression.is_Add:
        return sum(parts)
    if expression.is_Mul:
        return float(np.prod(parts))
    assert expression.is_Pow and expression.exp.is_Integer and expression.exp > 0, expression
    return parts[0] ** int(expression.exp)


def _residual_function(system):
    """The equations of ``system`` at a configuration ``q``, each relative to its scale (:func:`_absolute`: the
    Cayley map's denominator makes the terms large where the orientation is far from its chart's centre)."""
    import sympy as sp

    equations, unknowns, params, layout = system
    symbols = [*unknowns, *params]
    f = sp.lambdify(symbols, equations, "numpy")

    def residuals(model, q: np.ndarray) -> np.ndarray:
        at = _unknowns(model, q, [str(u) for u in unknowns], layout["R0"])
        values = [*at.values(), *(float(t) for t in q[:3])]  # the sliders: the parameters ta1…ta3
        scale = dict(zip(symbols, values, strict=True))
        return np.array(f(*values), dtype=float) / np.array([_absolute(e, scale) for e in equations])

    return residuals


def test_its_rows_close_at_every_configuration_and_nowhere_else(twisted, monkeypatch):
    m = twisted.description
    reduced = general_fk.build_system(m)
    assert [kind for kind, _last, _free in reduced[3]["legs"]] == ["sphere"] * 3
    assert len(reduced[1]) == 6  # the pose alone: each base joint eliminated, its row written through the sphere
    monkeypatch.setattr(general_fk, "_row_survives_elimination", lambda *args: False)
    whole = general_fk.build_system(m)
    assert [kind for kind, _last, _free in whole[3]["legs"]] == ["point"] * 3 and len(whole[1]) == 18
    rng = np.random.default_rng(5)
    on_reduced, on_whole = _residual_function(reduced), _residual_function(whole)
    for pose in rng.uniform(-0.05, 0.05, (4, 3)):
        q = mm.inverse_kinematics(twisted, pose, ())
        for residuals in (on_reduced, on_whole):
            assert np.abs(residuals(twisted, q)).max() < 1e-11  # measured: at most 2.5e-13
        off = q.copy()
        off[-3:] += 0.02  # the platform turned off the legs' closure
        assert np.abs(on_reduced(twisted, off)[1::2]).min() > 1e-6  # each leg's row; measured: 2.5e-5 and more
