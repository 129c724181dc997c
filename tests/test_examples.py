"""The example scripts in examples/ run as a user would run them."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted([*(Path(__file__).parents[1] / "examples").glob("*.py"),
                   *(Path(__file__).parents[1] / "examples" / "identification").glob("*.py")])


def _last_number(label: str, out: str) -> float:
    return float(re.findall(rf"{label}: *([0-9.eE+-]+)", out)[-1])


#: What an example promises, checked on what it prints.
PROMISES = {
    # the loop closed: the real machine's path error, calibrated and identified, within 3x the nominal case's
    "paper_loop.py": lambda out: _last_number("ratio to the nominal case", out) <= 3.0,
    # calibrated from selected poses: on 50 held-out poses, at most 2x the measurement noise
    "calibration.py": lambda out: max(_last_number("delta held-out error / noise", out),
                                      _last_number("stewart held-out error / noise", out)) <= 2.0,
}


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip()
    assert "Traceback" not in proc.stderr
    if script.name in PROMISES:
        assert PROMISES[script.name](proc.stdout), proc.stdout


def test_there_are_examples():
    assert len(EXAMPLES) >= 3
