"""Simulation: scenarios and their sampled-data and continuous-time runs (:mod:`~pkmlab.simulation.run`), the
plants integrated with a stiff ODE solver (:mod:`~pkmlab.simulation.plants`), and a plant's parameters drawn
around the controller's (:mod:`~pkmlab.simulation.uncertainty`)."""
