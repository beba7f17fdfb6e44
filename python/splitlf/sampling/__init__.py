"""Sampling: what a design records of the light field. Ray space (integration polygons
and footprints), coincidence planes and new samples (Eqs. 8–9), 2-D samples and coverage.
May import ``splitlf.model`` and below."""
