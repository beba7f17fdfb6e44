"""Render the seed design's figures into docs/ exactly as `splitlf figures` writes them.

Run from anywhere: python docs/make_figures.py
"""

from __future__ import annotations

from pathlib import Path

from splitlf.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["figures", "--out", str(Path(__file__).resolve().parent),
                          "--force"]))
