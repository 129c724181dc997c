"""The algorithms of pkmlab, each a function of a model (:func:`pkmlab.load`) and arrays shaped ``(..., n)``:
:mod:`~pkmlab.algorithms.kinematics` (inverse and forward kinematics, branch following, Jacobians,
singularity measure) and :mod:`~pkmlab.algorithms.dynamics` (the full-space constrained model with its
multipliers, the actuator-space model, inverse and forward dynamics). :mod:`pkmlab` re-exports them."""
