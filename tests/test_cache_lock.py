"""Two processes that need the same cached result at once (test workers, two commands started together): the
second waits for the first's and reads it, instead of computing it too (a generic instance's monodromy takes
tens of seconds)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

#: A process that asks pkmlab's cache for an array computed slowly, each computation leaving a line in a log.
SCRIPT = """
import sys, time
import numpy as np
from pkmlab.numerics.homotopy import cached_arrays

def compute():
    with open(sys.argv[1], "a") as log:
        log.write("computed\\n")
    time.sleep(2.0)
    return {"x": np.arange(3.0)}

print(cached_arrays("lock-test", compute, "computing")["x"].sum())
"""


def test_a_result_two_processes_need_at_once_is_computed_once(tmp_path):
    log = tmp_path / "log.txt"
    env = {**os.environ, "PKMLAB_CACHE_DIR": str(tmp_path / "cache")}
    procs = [subprocess.Popen([sys.executable, "-c", SCRIPT, str(log)], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outputs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outputs
    assert [float(out.strip()) for out, _err in outputs] == [3.0, 3.0]
    assert log.read_text().splitlines() == ["computed"]
    assert sum("computing" in err for _out, err in outputs) == 1  # the notice, said by the process that computes
    saved = list((tmp_path / "cache").glob("numba-*/generic/lock-test.npz"))
    assert len(saved) == 1 and np.load(saved[0])["x"].tolist() == [0.0, 1.0, 2.0]


def test_a_function_compiled_without_its_python_wrapper_refuses_a_call_from_python():
    """The compiled core's internal functions have no wrapper for Python's arguments (NO_WRAPPERS): Numba would call
    the missing wrapper and end the process (its issue 2541); pkmlab's refuse in one line naming the function."""
    import pytest

    import pkmlab
    from pkmlab import _compile_cache

    if _compile_cache.INTERPRETED:
        pytest.skip("interpreted: the kernels are Python functions")
    kernels = pkmlab.load("paper").kernels
    with pytest.raises(TypeError, match=r"\.block_lu_solve is called from compiled code only"):
        kernels.block_lu_solve(np.eye(6), np.arange(6), np.ones(6))


#: A process that imports Numba through pkmlab or before it, then reports whether a typing error's message is
#: highlighted for a terminal and whether Numba's switch is left in its environment.
HIGHLIGHT = """
import os, sys
if sys.argv[1] == "numba first":
    import numba
from pkmlab import _compile_cache
import numba
try:
    numba.njit(lambda x: x.no_such_attribute)(1.0)
except numba.core.errors.TypingError as exc:
    print("\\x1b[" in str(exc), "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING" in os.environ)
"""


def test_numba_imported_by_pkmlab_formats_its_typing_errors_plain_and_leaves_the_environment_as_it_was():
    """Numba's typing errors without terminal highlighting where pkmlab imports Numba first (formatting them
    through colorama costs a few percent of a first compile), the environment as it was after; where Numba was
    imported first, its messages are its own."""
    import pytest

    pytest.importorskip("colorama")  # (Numba highlights through it: without it, its messages are plain anyway)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    env.pop("PKMLAB_INTERPRETED", None)

    def run(order: str) -> str:
        return subprocess.run([sys.executable, "-c", HIGHLIGHT, order], capture_output=True, text=True, env=env,
                              check=True).stdout.strip()

    assert run("pkmlab first") == "False False"
    assert run("numba first") == "True False"


#: A process that lets pkmlab import Numba, compiles one kernel, and reports where Numba keeps it.
KEPT = """
import sys
from pathlib import Path
import numpy as np
import pkmlab
from pkmlab import _compile_cache
from pkmlab.model import mechanism_model as mm
import numba
model = pkmlab.load("five_bar")
mm.trig_table(model, np.zeros(len(model.coordinates)))  # compiled here, and saved
cache = Path(_compile_cache.CACHE_DIR)
print(numba.config.CACHE_DIR == str(cache), cache.is_relative_to(sys.argv[1]), any(cache.rglob("*.trig-*.nbi")))
"""


def test_the_kernels_compiled_after_pkmlab_imported_numba_are_kept_in_its_cache_folder(tmp_path):
    """Numba reads its settings from the environment again at a compile where the environment changed: pkmlab's
    import of Numba, which sets and takes back the switch of its error highlighting, must not leave a change for that
    compile to find — it would set Numba's cache folder back to the default, the sources' own folders, where an
    edit of another module is not seen."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.pop("PKMLAB_INTERPRETED", None)
    env["PKMLAB_CACHE_DIR"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", KEPT, str(tmp_path)], capture_output=True, text=True, env=env,
                         check=True).stdout.strip()
    assert out == "True True True"


#: The same, a NUMBA_ variable set by the program after pkmlab imported Numba and compiled, then another structure's
#: kernels imported and compiled.
KEPT_AFTER_A_SETTING = """
import os, sys
from pathlib import Path
import numpy as np
import pkmlab
from pkmlab import _compile_cache
from pkmlab.model import mechanism_model as mm
import numba
five_bar = pkmlab.load("five_bar")
mm.trig_table(five_bar, np.zeros(len(five_bar.coordinates)))
os.environ["NUMBA_DEBUG_CACHE"] = "0"  # the program's own setting: Numba reads its settings again at the next compile
mm.trig_table(five_bar, np.zeros(len(five_bar.coordinates), dtype=np.float32))  # (another signature: a compile)
assert numba.config.CACHE_DIR != str(_compile_cache.CACHE_DIR)  # Numba's default again
paper = pkmlab.load("paper")  # kernels decorated after Numba read its settings again
mm.trig_table(paper, np.zeros(len(paper.coordinates)))
cache = Path(_compile_cache.CACHE_DIR)
print(sorted(p.name.split(".")[0] for p in cache.rglob("*.trig-*.nbi")),
      [str(p) for p in Path(pkmlab.__file__).parent.rglob("*.nbi") if p.stat().st_mtime > float(sys.argv[2])])
"""


def test_kernels_decorated_after_the_program_changes_a_numba_setting_are_kept_in_pkmlabs_cache_folder(tmp_path):
    """A NUMBA_ variable set by the program after pkmlab imported Numba: Numba then reads its settings again, its
    cache folder among them; kernels decorated after (another structure's) are kept in pkmlab's cache folder all
    the same, none beside the sources."""
    import time

    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.pop("PKMLAB_INTERPRETED", None)
    env["PKMLAB_CACHE_DIR"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", KEPT_AFTER_A_SETTING, str(tmp_path), str(time.time() - 1)],
                         capture_output=True, text=True, env=env, check=True).stdout.strip()
    assert out == "['planar_RaRR_RaRR_RaRR_rigid', 'planar_RaRR_RaRR_point'] []"
