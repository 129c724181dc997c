"""Kernels generated from mechanism descriptions (``python -m pkmlab.derivations.planar``): one module per
structure, named after it; do not edit."""
