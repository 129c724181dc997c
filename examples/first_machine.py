"""A first machine: the paper's planar 3-RRR, its kinematics both ways, and one closed-loop run."""

import pkmlab

model = pkmlab.load("paper")  # a preset, a description file (TOML) or a description
ik = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(-1, 1, -1))  # pose x, y (m), alpha (rad)
print("actuator angles theta (rad):", ik.theta)

fk = pkmlab.forward_kinematics(model, ik.theta)  # every assembly mode of these actuator angles
for mode in fk:
    print("pose", mode.pose, "S", mode.S)

result = pkmlab.simulate(pkmlab.paper_scenario("nominal"))  # the paper's nominal case, computed torque
print("largest path error (m):", result.summary()["max_path_error_m"])
