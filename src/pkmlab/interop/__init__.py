"""MuJoCo interoperability: any machine exported as MJCF (:mod:`~pkmlab.interop.mujoco_export`) and MuJoCo as a
plant under pkmlab's controller (:mod:`~pkmlab.interop.mujoco_plant`)."""
