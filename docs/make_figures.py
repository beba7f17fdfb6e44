"""Render the figures in docs/ exactly as `splitlf figures` writes them: the seed camera's
into docs/, and each preset design's into docs/presets/NAME/ (docs/architectures.md).

Run from anywhere: python docs/make_figures.py
"""

from __future__ import annotations

from pathlib import Path

from splitlf.cli import main
from splitlf.model.design import PRESETS

if __name__ == "__main__":
    docs = Path(__file__).resolve().parent
    code = main(["figures", "--out", str(docs), "--force"])
    for name in PRESETS:
        code = code or main(["figures", "--preset", name, "--out",
                             str(docs / "presets" / name), "--force"])
    raise SystemExit(code)
