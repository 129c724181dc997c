"""Gain tuning on the paper's fast case: how the tracking error and the peak torque change with kp.

Each run is one call of pkmlab.simulate on a modified paper scenario (kv = 2 sqrt(kp)).
Run: .venv/bin/python examples/gain_sweep.py
"""

import pkmlab
from pkmlab.control.controller import ControllerSpec

base = pkmlab.paper_scenario("fast")
print(f"{'kp':>8} {'max path error (mm)':>20} {'peak torque (N m)':>18}")
for kp in (100.0, 300.0, 1000.0, 3000.0):
    result = pkmlab.simulate(base.replace(controller=ControllerSpec("computed_torque", kp=kp)))
    s = result.summary()
    print(f"{kp:>8g} {s['max_path_error_m'] * 1e3:>20.4f} {max(s['peak_torque_Nm']):>18.4f}")
