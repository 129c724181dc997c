"""A tour of pkmlab's kinematics on the paper's 3-RRR: IK, every FK assembly mode, Jacobians.

Run: .venv/bin/python examples/kinematics_tour.py
"""

import numpy as np

import pkmlab

model = pkmlab.Planar3RRR.paper()
pose = [0.20, 0.21, 0.0]

ik = pkmlab.inverse_kinematics(model, pose)  # all 8 working modes
for mode, q, s in zip(ik.modes, ik.q, ik.S, strict=True):
    print(f"working mode {tuple(int(m) for m in mode)}: theta = {np.round(q[:3], 4)}, S = {s:+.3f}")

best = int(np.argmax(np.abs(ik.S)))
fk = pkmlab.forward_kinematics(model, ik.theta[best])
print(f"\n{len(fk)} assembly modes for theta = {np.round(ik.theta[best], 4)}:")
for sol in fk:
    print(f"  pose = {np.round(sol.pose, 4)}, S = {sol.S:+.3f}")

q = fk.nearest(pose).q
print("\nvelocity Jacobian Jv (eq. 16):\n", np.round(pkmlab.velocity_jacobian(model, q), 4))
theta_dot = np.array([0.5, -0.2, 0.3])
print("passive rates (phi1, phi2, phi3, alpha):", np.round(pkmlab.passive_rates(model, q, theta_dot), 4))
