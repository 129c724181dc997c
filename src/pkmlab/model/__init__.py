"""The model: a description bound to its structure's packed parameters and generated kernels
(:class:`~pkmlab.model.mechanism_model.MechanismModel`, :func:`pkmlab.load`), immutable, apart from any state."""
