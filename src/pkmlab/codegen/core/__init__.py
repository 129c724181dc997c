"""The compiled core of every described mechanism: branch following, actuator-space dynamics,
the controller and the sampled-data loop — written once, for any structure.

This package is a *template*, in parts by concern (:data:`PARTS`). :mod:`pkmlab.codegen.planar`
appends the text below each part's ``TEMPLATE`` marker to every structure's generated kernel module, in
that order, where the names it uses (``constraints``, ``constraint_jacobian``, ``body_jacobians``,
``N_COORDINATES``, …) are that structure's generated code. Each structure thus gets its own compiled
loop, bound to its own kernels at compile time and cached on disk like any other module (Numba's cache cannot hold a
loop that receives kernels as arguments: each process would compile it again). The
generated text is checked to be current by the test suite, so these files are the one source.

Conventions (as in the generated kernels): ``q = (θ, φ)`` with the ``n`` actuator values ``θ``
first and the passive coordinates ``φ`` (the passive joints, then the pose) after them;
``η(q) = 0`` are the ``m = len(φ)`` loop-closure equations; ``P`` is the packed parameter vector.
Every generated kernel reads the angles' cosines and sines from a trig table ``sc`` (N, 2) of its
configuration (``trig``), computed once per configuration and shared by every kernel evaluated there.
Every function is allocation-free and works in a :class:`Workspace`.
"""

from __future__ import annotations

from pathlib import Path

#: The parts of the compiled core, in the order their text is appended to a generated module.
PARTS = ("workspace", "branch_following", "dynamics", "control", "loop", "entry_points")


def template() -> str:
    """The compiled core's text that every structure's generated module carries: each part's text below its
    ``TEMPLATE`` marker, in the order of :data:`PARTS`."""
    out = []
    for part in PARTS:
        text = (Path(__file__).resolve().parent / f"{part}.py").read_text()
        marker = text.index("\n# ==== TEMPLATE")
        out.append(f"# ---- pkmlab.codegen.core.{part}, bound to the kernels above ----\n"
                   + text[text.index("\n", marker + 1) + 1:])
    return "\n\n" + "\n\n".join(out)
