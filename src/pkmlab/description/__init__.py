"""The description of a mechanism — the model as data: legs of joints, bodies, the platform, strokes and
gravity (:mod:`~pkmlab.description.mechanism` for planar machines, :mod:`~pkmlab.description.spatial` for
spatial ones), the leg types' closed forms, the presets, and the TOML form of every description
(:mod:`~pkmlab.description.files`). Nothing here is compiled; :mod:`pkmlab.model` binds a description to
its structure's kernels."""
