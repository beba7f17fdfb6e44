"""Inversion: from a raw back to the scene. The 1-D simulation, reconstruction, depth
estimation and the image-quality measures (§11). May import ``splitlf.imaging``,
``splitlf.sampling``, ``splitlf.model`` and below."""
