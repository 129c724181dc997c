"""A tour of pkmlab's kinematics on the paper's 3-RRR: IK, every FK assembly mode, Jacobians — the same
calls for every machine (try ``pkmlab.load("five_bar")`` or ``pkmlab.load("delta")`` with a pose of theirs).

Run: .venv/bin/python examples/kinematics_tour.py
"""

import numpy as np

import pkmlab

model = pkmlab.load("paper")
pose = [0.20, 0.21, 0.0]
print(f"{model.name}: q = ({', '.join(model.coordinates)})")

ik = pkmlab.inverse_kinematics(model, pose)  # all 8 working modes
for mode, theta, s in zip(ik.modes, ik.theta, ik.S, strict=True):
    print(f"working mode {tuple(int(m) for m in mode)}: theta = {np.round(theta, 4)}, S = {s:+.3f}")

best = int(np.argmax(np.abs(ik.S)))
fk = pkmlab.forward_kinematics(model, ik.theta[best])
print(f"\n{len(fk)} assembly modes for theta = {np.round(ik.theta[best], 4)}:")
for sol in fk:
    print(f"  pose = {np.round(sol.pose, 4)}, S = {sol.S:+.3f}")

q = fk.nearest(pose).q
print("\nvelocity Jacobian Jv = d pose / d theta (eq. 16):\n", np.round(pkmlab.velocity_jacobian(model, q), 4))
theta_dot = np.array([0.5, -0.2, 0.3])
print("coordinate rates q_dot:", np.round(pkmlab.coordinate_rates(model, q, theta_dot), 4))
reduced = pkmlab.actuator_space_model(model, q, theta_dot)
print("actuator-space mass matrix M (eq. 35):\n", np.round(reduced.M, 5))
