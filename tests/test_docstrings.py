"""The worked examples in the docstrings run and give what they show."""

import doctest
import importlib

import pytest

MODULES = ["pkmlab", "pkmlab.algorithms.kinematics", "pkmlab.algorithms.dynamics", "pkmlab.plants", "pkmlab.geometry",
           "pkmlab.kinematics", "pkmlab.polynomial", "pkmlab.analysis", "pkmlab.dynamics",
           "pkmlab.control", "pkmlab._format", "pkmlab.mechanisms.description", "pkmlab.mechanisms.files",
           "pkmlab.mechanism_model", "pkmlab.animation",
           "pkmlab.mechanisms.stewart_fk", "pkmlab.uncertainty", "pkmlab.progress"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
