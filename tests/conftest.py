import os
import shutil
import subprocess
import sys
from pathlib import Path

# The suite compiles its kernels at LLVM's optimisation level 1, before anything imports Numba: the same numbers
# (arithmetic without fast-math is not reordered at any level; benchmarks/check_numbers.py --compare run at level 1
# gives 0.0), about 8 % less compile time, which is most of a fresh run's. Benchmarks and users compile at level 3,
# into a cache folder of their own (pkmlab._compile_cache.cache_folder).
os.environ.setdefault("NUMBA_OPT", "1")
# A first run's loop is not compiled ahead in a second process (pkmlab.simulation.ahead): the suite's workers share
# the cores already, and a test's own subprocess (a command killed mid-run) must leave no second one behind.
os.environ.setdefault("PKMLAB_COMPILE_AHEAD", "0")

import numpy as np
import pytest
from hypothesis import settings

# Test runs must not depend on luck: a fixed example sequence, no example database, unless
# PKMLAB_EXPLORE=1 asks hypothesis to explore new examples (then fix what it finds).
settings.register_profile("ci", derandomize=True, database=None, deadline=None)
settings.register_profile("explore", deadline=None)
settings.load_profile("explore" if os.environ.get("PKMLAB_EXPLORE") else "ci")


def _without_local_constants() -> None:
    """Hypothesis also draws numbers and strings it finds in the code under test (an editable install's modules,
    and the kernels generated into the cache folder), from the modules imported so far: which depends on the tests
    a worker ran before, so a derandomized test drew other inputs from run to run (the API fuzzer found an overflow
    in one run of three). A fixed sequence needs a fixed pool: the one Hypothesis starts with, empty. (Its private
    hook: where a version of Hypothesis has none, nothing is changed.)"""
    try:
        from hypothesis.internal.conjecture import providers
    except ImportError:
        return
    if callable(getattr(providers, "_get_local_constants", None)) and hasattr(providers, "_local_constants"):
        empty = providers._local_constants
        providers._get_local_constants = lambda: empty


if not os.environ.get("PKMLAB_EXPLORE"):
    _without_local_constants()

sys.path.insert(0, str(Path(__file__).parent))

import pkmlab  # noqa: E402
from pkmlab.cli import main  # noqa: E402
from pkmlab.description.presets import PRESETS  # noqa: E402
from pkmlab.paper import kinematics as kin  # noqa: E402
from pkmlab.paper.geometry import Planar3RRR  # noqa: E402

# Every shipped machine structure bound once as the session starts: on a fresh checkout the first binding of each
# says on stderr that its kernels compile as they are first used, a line of the session's, not of a test's.
for _preset in PRESETS:
    pkmlab.load(_preset)

#: Files whose tests are about the spatial presets (the Delta, the Stewart platform), or run them (the documentation
#: site's build runs the tutorials, the Delta's among them); tests elsewhere whose name or parameters name a machine of
#: WARMED count too.
SPATIAL_FILES = {"test_delta.py", "test_stewart.py", "test_stewart_fk.py", "test_spatial_kernels.py",
                 "test_lower_mobility.py", "test_upu.py", "test_singularity_kinds.py", "test_rrs.py",
                 "test_catalogue_fk.py", "test_docs_site.py"}
#: Tests of the spatial presets that neither file nor name says: examples that calibrate a Delta and a Stewart, the
#: Delta's dynamics over a batch of leading axes.
SPATIAL_TESTS = {"test_example_runs[calibration.py]", "test_dynamics_are_batched_over_leading_axes"}
#: Below this many selected tests, the spatial kernels are not compiled ahead (a few tests run as usual).
WARM_FROM = 200
_warm: subprocess.Popen | None = None


#: Machines warm_kernels.py compiles whose name, in a test's parameters, makes it one of the spatial tests.
WARMED = ("delta", "stewart", "6rus", "6pus")


#: The test files that take longest from an empty kernel cache (measured: 20 to 65 s each), longest first: a run by
#: several workers (``make test``) hands out whole files in this order, then the others, so that the workers finish
#: together rather than one of them starting a long file as the other ends.
LONGEST_FILES = ("test_mujoco_export.py", "test_api_validation.py", "test_study.py", "test_docs_site.py",
                 "test_api.py", "test_machine_simulation.py", "test_actuation_redundancy.py",
                 "test_leg_of_two_actuators.py", "test_output_safety.py",
                 "test_scenarios.py", "test_catalogue_fk.py", "test_catalogue_runs.py", "test_catalogue_kinematics.py",
                 "test_kinematic_redundancy.py", "test_overconstrained.py", "test_spatial_general_legs.py",
                 "test_identification.py", "test_delta.py")


def _first_files(item) -> int:
    name = item.path.name
    return LONGEST_FILES.index(name) if name in LONGEST_FILES else len(LONGEST_FILES)


def _spatial(item) -> bool:
    name = item.name.lower()
    return item.path.name in SPATIAL_FILES or any(m in name for m in WARMED) or item.name in SPATIAL_TESTS


def pytest_collection_modifyitems(session, config, items):
    """Run the tests of the spatial presets last and compile their kernels meanwhile, in a second process
    (``warm_kernels.py``) on the core the tests leave idle: their first compiles are the largest cost of a
    run from a fresh checkout, and the tests then load them from the on-disk kernel cache.

    Not in a run by several workers (``pytest -n``, as ``make test`` runs): they share the cores already, and a
    function two of them reach at once compiles once (``pkmlab._compile_cache``)."""
    global _warm
    if hasattr(config, "workerinput"):
        items.sort(key=_first_files)
        return
    items.sort(key=_spatial)  # stable: each group keeps its order
    if len(items) >= WARM_FROM and any(_spatial(item) for item in items) and not os.environ.get("PKMLAB_INTERPRETED"):
        # at the lowest priority: the tests' own subprocesses (a browser drawing a page, Dask workers) come first
        _warm = subprocess.Popen([sys.executable, str(Path(__file__).parent / "warm_kernels.py")],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=lambda: os.nice(19))


def pytest_runtest_setup(item):
    if _warm is not None and _spatial(item):
        _warm.wait()  # compiling both would only take the tests' own core too


def pytest_sessionfinish(session, exitstatus):
    if _warm is not None and _warm.poll() is None:
        _warm.kill()
        _warm.wait()


@pytest.fixture(scope="session")
def paper():
    return Planar3RRR.paper()


def random_reachable_poses(rng, model, n, margin=0.05):
    """Random platform poses reachable in at least one working mode with |S| > margin."""
    out = []
    while len(out) < n:
        pose = np.array([rng.uniform(0.1, 0.42), rng.uniform(0.05, 0.38), rng.uniform(-0.8, 0.8)])
        ik = kin.inverse_kinematics(model, pose, on_unreachable="nan")
        if np.any(np.abs(ik.S) > margin):
            out.append(pose)
    return np.array(out)


def run(capsys, *argv) -> tuple[int, str, str]:
    """Run the ``pkmlab`` command in-process: ``(exit code, stdout, stderr)``."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_shot(*argv: str) -> tuple[dict, bool]:
    """``pkmlab ARGV --json`` in a new process started as the executable starts it (one-shot commands
    interpreted): its JSON result, and whether Numba was imported. Fails on a non-zero exit or a traceback."""
    import json
    import subprocess

    code = ("import json, sys\nfrom pkmlab.cli import main\n"
            f"code = main({[str(a) for a in argv] + ['--json']!r}, one_shot_interpreted=True)\n"
            "print(json.dumps({'numba': 'numba' in sys.modules, 'code': code}))")
    env = {k: v for k, v in os.environ.items() if k != "PKMLAB_INTERPRETED"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    result_text, status_text = out.stdout.rsplit("\n", 2)[:2]
    status = json.loads(status_text)
    assert status["code"] == 0, out.stderr
    return json.loads(result_text), status["numba"]


def assert_user_error(code: int, out: str, err: str) -> str:
    """Exit 1, nothing on stdout, exactly one line on stderr, no traceback; returns the message."""
    assert code == 1
    assert out == ""
    assert "Traceback" not in err
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1, err
    assert lines[0].startswith("pkmlab"), err
    assert err.endswith("\n")
    return lines[0]


#: Debian's Chromium, which the views' and the documentation site's tests open pages in (make test installs it).
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium for a test module's pages (skipped without Chromium or playwright)."""
    if CHROMIUM is None:
        pytest.skip("Chromium is not installed (make test installs Debian's chromium)")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", "--no-first-run", "--disable-quic"])
        yield b
        b.close()
