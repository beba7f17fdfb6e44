"""Image formation: textures, scenes and the renderer of raw sensor images (§10).
May import ``splitlf.model`` and below."""
