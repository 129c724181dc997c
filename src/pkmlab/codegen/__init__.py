"""Code generation: the SymPy derivations of every structure's kinematics and body velocities
(:mod:`~pkmlab.codegen.planar`, :mod:`~pkmlab.codegen.spatial`), the 3-RRR's forward-kinematics sextic
(:mod:`~pkmlab.codegen.rrr3_sextic`), and the compiled core's template (:mod:`~pkmlab.codegen.core`)
that every generated module in :mod:`pkmlab.kernels` carries. ``make derive`` regenerates the kernels."""
