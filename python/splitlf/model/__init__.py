"""The camera model: designs (channels, lattices, lens types, layouts; docs/model.md §9),
the paper's split-sensor camera, presets, and the closed forms over depth (Eqs. 1–7).
May import ``splitlf.errors``, the private helpers and the native module only."""
