"""The command line run in-process, for the CLI tests: its exit status and output, and a
small raw file to feed depth and reconstruct."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import splitlf
from splitlf.cli import main


def run_cli(argv: list[str], capsys: Any) -> tuple[Any, str, str]:
    """Exit status, stdout, stderr of ``splitlf ARGV`` (argparse's own exits included)."""
    try:
        code = main(argv)
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def small_raw(folder: Path, lenses: tuple[int, int], *render_args: str,
              capsys: Any = None) -> Path:
    """``folder``/r.npz: the raw that ``splitlf render`` writes for the seed design with
    ``lenses`` = (Kx, Ky) microlenses per half and ``render_args`` (texture, depth, ...);
    its output is read off ``capsys`` when given."""
    d = splitlf.Design.preset("seed")
    d = d.replace(channels=tuple(c.replace(Kx=lenses[0], Ky=lenses[1]) for c in d.channels))
    toml = folder / "d.toml"
    toml.write_text(d.to_toml())
    raw = folder / "r.npz"
    assert main(["render", str(toml), *render_args, "-o", str(raw)]) == 0
    if capsys is not None:
        capsys.readouterr()
    return raw
