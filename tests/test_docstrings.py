"""The worked examples in the docstrings run and give what they show."""

import doctest
import importlib

import pytest

MODULES = ["pkmlab", "pkmlab.algorithms.kinematics", "pkmlab.algorithms.dynamics", "pkmlab.simulation.plants",
           "pkmlab.paper.geometry", "pkmlab.paper.kinematics", "pkmlab.numerics.polynomial",
           "pkmlab.algorithms.analysis", "pkmlab.paper.dynamics", "pkmlab.control.controller", "pkmlab._format",
           "pkmlab.description.mechanism", "pkmlab.description.files", "pkmlab.model.mechanism_model",
           "pkmlab.views.animation", "pkmlab.algorithms.stewart_fk", "pkmlab.simulation.uncertainty", "pkmlab.progress",
           "pkmlab.algorithms.singularities", "pkmlab.control.time_optimal",
           "pkmlab.algorithms.regressor", "pkmlab.simulation.run", "pkmlab.simulation.scenario",
           "pkmlab.simulation.result", "pkmlab.formats.scenario", "pkmlab.errors",
           "pkmlab.algorithms.identification", "pkmlab.study.definition", "pkmlab.study.sweep", "pkmlab.study.tuning",
           "pkmlab.views.notebook", "pkmlab.algorithms.calibration", "pkmlab.algorithms.consistency",
           "pkmlab.formats.measurements", "pkmlab.cli", "pkmlab.algorithms.redundancy"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
