"""Exchange with the light field ecosystem (docs/export.md): :func:`export` writes a raw,
its design's white image and micro-image centres in the files PlenoptiCam, plenpy or any
TIFF reader takes."""
