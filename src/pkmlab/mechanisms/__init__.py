"""Mechanism families: compiled kernels per machine."""

from .. import _compile_cache  # noqa: F401  (sets the kernel cache before any kernel is defined)
