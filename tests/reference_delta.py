"""An independent statement of the Delta robot of pkmlab's conventions (docs/conventions.md, the
``delta`` preset), written from its geometry alone — no pkmlab code — for the tests to check the
generated kernels against: inverse kinematics per arm, the three-sphere forward kinematics, the
singularity measure ``det[P_i - E_i] / L_b³`` and the actuator-space model from the kinetic energy
``Σ ½ J θ̇² + (m_f/6)(|Ė|² + Ė·Ṗ + |Ṗ|²) + ½ m_p |Ṗ|²`` and the potential energy."""

from __future__ import annotations

import numpy as np

R_B, L_A, L_B, R_P = 0.20, 0.35, 0.80, 0.05
M_ARM, J_ARM, M_FORE, M_PLATFORM, G = 0.40, 0.0183, 0.10, 0.30, 9.81
GAMMA = np.arange(3) * 2 * np.pi / 3
W = np.column_stack([np.cos(GAMMA), np.sin(GAMMA), np.zeros(3)])
EZ = np.array([0.0, 0.0, 1.0])


def elbows(theta):
    theta = np.asarray(theta, dtype=float)
    return R_B * W + L_A * (np.cos(theta)[:, None] * W - np.sin(theta)[:, None] * EZ)


def inverse_kinematics(p, knee_out=(True, True, True)):
    """θ_i such that |P + R_p w_i - E_i| = L_b, the elbow farther from the z axis where asked (the other
    root elsewhere)."""
    out = []
    for i in range(3):
        d = np.asarray(p) + R_P * W[i] - R_B * W[i]
        # |d - L_a (c w - s ez)|² = L_b²: 2 L_a (d·w c - d·ez s) = |d|² + L_a² - L_b²
        a, b = 2 * L_A * d @ W[i], -2 * L_A * d @ EZ
        c = d @ d + L_A**2 - L_B**2
        roots = np.arctan2(b, a) + np.array([1, -1]) * np.arccos(c / np.hypot(a, b))
        reach = [abs(R_B + L_A * np.cos(t)) for t in roots]  # the elbow's distance from the z axis
        out.append(roots[int(np.argmax(reach))] if knee_out[i] else roots[int(np.argmin(reach))])
    return np.angle(np.exp(1j * np.array(out)))


def positions(theta):
    """Both platform positions (lowest first) by the three-sphere intersection, solved as
    two planes and a sphere."""
    c = elbows(theta) - R_P * W
    a = 2 * (c[1:] - c[0])  # |p - c_i|² = |p - c_0|²  ->  a p = b
    b = (c[1:] ** 2).sum(1) - (c[0] ** 2).sum()
    n = np.cross(a[0], a[1])
    p0 = np.linalg.lstsq(a, b, rcond=None)[0]
    # p = p0 + t n on the sphere around c_0
    k2, k1, k0 = n @ n, 2 * n @ (p0 - c[0]), (p0 - c[0]) @ (p0 - c[0]) - L_B**2
    disc = k1 * k1 - 4 * k2 * k0
    ts = (-k1 + np.array([-1, 1]) * np.sqrt(disc)) / (2 * k2)
    return sorted([p0 + t * n for t in ts], key=lambda p: p[2])


def singularity_measure(theta, p):
    return np.linalg.det(np.asarray(p) + R_P * W - elbows(theta)) / L_B**3


def jacobians(theta, p):
    """J_E (3 elbows, 3, 3) and J_P (3, 3): Ė_i = J_E[i] θ̇, Ṗ = J_P θ̇, from (P_i - E_i)·(Ṗ - Ė_i) = 0."""
    theta = np.asarray(theta, dtype=float)
    je = np.zeros((3, 3, 3))
    for i in range(3):
        je[i, :, i] = L_A * (-np.sin(theta[i]) * W[i] - np.cos(theta[i]) * EZ)
    d = np.asarray(p) + R_P * W - elbows(theta)
    jp = np.linalg.solve(d, np.array([d[i] @ je[i] for i in range(3)]))
    return je, jp


def mass_matrix(theta, p):
    je, jp = jacobians(theta, p)
    m = J_ARM * np.eye(3) + M_PLATFORM * jp.T @ jp
    for i in range(3):
        cross = je[i].T @ jp
        m += M_FORE / 3 * (je[i].T @ je[i] + (cross + cross.T) / 2 + jp.T @ jp)
    return m


def potential(theta, p):
    z_e = elbows(theta)[:, 2]
    z_arm = (-L_A / 2 * np.sin(np.asarray(theta)))
    return G * (M_ARM * z_arm.sum() + M_FORE * ((z_e + p[2]) / 2).sum() + M_PLATFORM * p[2])


def knee_gap(p) -> float:
    """How much farther from the z axis the outer elbow is than the inner one, the smallest over the legs
    (0 where a leg's two roots are as far: the working modes are not told apart there)."""
    gaps = []
    for i in range(3):
        d = np.asarray(p) + R_P * W[i] - R_B * W[i]
        a, b = 2 * L_A * d @ W[i], -2 * L_A * d @ EZ
        c = d @ d + L_A**2 - L_B**2
        roots = np.arctan2(b, a) + np.array([1, -1]) * np.arccos(np.clip(c / np.hypot(a, b), -1, 1))
        reach = [abs(R_B + L_A * np.cos(t)) for t in roots]
        gaps.append(abs(reach[0] - reach[1]))
    return min(gaps)
