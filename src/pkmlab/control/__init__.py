"""Control: the desired motion (:mod:`~pkmlab.control.trajectory`) and the controllers that track it — computed
torque and PD, sampled-data or continuous (:mod:`~pkmlab.control.controller`)."""
