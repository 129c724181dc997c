"""File formats: scenario files (:mod:`~pkmlab.formats.scenario`) and the 3-RRR parameter files of pkmlab 0.2
(:mod:`~pkmlab.formats.params`, deprecated). Description files are the descriptions' own
(:mod:`pkmlab.description.files`)."""
