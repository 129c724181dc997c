"""Generated code — do not edit: one compiled module per structure (``python -m pkmlab.codegen.planar``,
``python -m pkmlab.codegen.spatial``), named after it, and the 3-RRR's sextic (``python -m
pkmlab.codegen.rrr3_sextic``)."""
