"""The paper's own formulation of its 3-RRR — 7 coordinates ``(θ, φ, α)``, the constraints of eqs. (2)–(6), the
forward-kinematics sextic, the full model with its multipliers — kept as an independent oracle of the generic
model (what the tests and benchmarks compare it with) and to read the parameter files of pkmlab 0.2."""
