"""The example scripts in examples/ run as a user would run them."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted([*(Path(__file__).parents[1] / "examples").glob("*.py"),
                   *(Path(__file__).parents[1] / "examples" / "identification").glob("*.py")])


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip()
    assert "Traceback" not in proc.stderr


def test_there_are_examples():
    assert len(EXAMPLES) >= 3
