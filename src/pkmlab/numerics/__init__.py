"""Numerics every layer above builds on: the closed-chain linear algebra (:mod:`~pkmlab.numerics.closed_chain`),
the Lagrangian of the bodies (:mod:`~pkmlab.numerics.lagrangian`), polynomial roots
(:mod:`~pkmlab.numerics.polynomial`)."""
