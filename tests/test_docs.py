"""Every code block of README.md and docs/*.md runs here, so a snippet that stops working
fails the test suite.

Rules of the collector (one test per Markdown file, blocks run in order):

- ```python blocks run in one namespace per file, in a fresh temporary directory.
- A ```text block right after a python block is that block's expected standard output
  (compared line by line, trailing spaces ignored).
- A ```toml block whose first line is a comment ``# NAME.toml`` is written to NAME.toml in
  the temporary directory (for the shell blocks that follow).
- ```sh blocks run with bash only when preceded by ``<!-- doctest: run -->``; the others
  are install or cluster commands and are not run (the README's two commands are what CI
  runs as ``.ci/run``).
- Any block preceded by ``<!-- doctest: skip (REASON) -->`` is skipped, and the reason
  is reported.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

FENCE = re.compile(r"^```(\w*)\s*$")
MARK = re.compile(r"^<!--\s*doctest:\s*(skip|run)\s*(?:\((.*)\))?\s*-->\s*$")


@dataclass
class Block:
    lang: str
    code: str
    line: int
    mark: str | None = None
    reason: str = ""


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown file with the doctest mark just above each."""
    out: list[Block] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    i, mark, reason = 0, None, ""
    while i < len(lines):
        m = MARK.match(lines[i].strip())
        if m:
            mark, reason = m.group(1), m.group(2) or ""
            i += 1
            continue
        f = FENCE.match(lines[i])
        if f:
            start, body = i + 1, []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            out.append(Block(f.group(1), "\n".join(body) + "\n", start, mark, reason))
            mark, reason = None, ""
        elif lines[i].strip():
            mark, reason = None, ""
        i += 1
    return out


def test_collector_finds_the_readme_snippets():
    found = blocks(ROOT / "README.md")
    assert sum(b.lang == "python" for b in found) >= 4
    assert any(b.mark == "skip" and b.reason for b in found)
    assert any(b.lang == "text" for b in found)


def _run_sh(code: str, where: Path, label: str) -> None:
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=where, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{label} failed:\n{proc.stdout}\n{proc.stderr}"


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_markdown_code_blocks_run(path: Path, tmp_path: Path, monkeypatch):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"doc_{path.stem}"}
    found = blocks(path)
    skipped: list[str] = []
    last_stdout: str | None = None
    for b in found:
        label = f"{path.name}:{b.line} ({b.lang})"
        if b.mark == "skip":
            skipped.append(f"{label}: {b.reason}")
            last_stdout = None
            continue
        if b.lang == "python":
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(compile(b.code, label, "exec"), namespace)  # noqa: S102
            last_stdout = buf.getvalue()
        elif b.lang == "text":
            assert last_stdout is not None, f"{label}: output block with no python block before"
            want = [ln.rstrip() for ln in b.code.strip("\n").splitlines()]
            got = [ln.rstrip() for ln in last_stdout.strip("\n").splitlines()]
            assert got == want, f"{label}: printed\n{last_stdout}"
            last_stdout = None
        elif b.lang == "toml":
            first = b.code.splitlines()[0] if b.code.strip() else ""
            m = re.match(r"#\s*([\w.-]+\.toml)\s*$", first)
            if m:
                (tmp_path / m.group(1)).write_text(b.code, encoding="utf-8")
        elif b.lang == "sh" and b.mark == "run":
            assert shutil.which("splitlf") or (Path(sys.executable).parent / "splitlf").exists()
            _run_sh(b.code, tmp_path, label)
    if skipped:
        print("skipped blocks:\n  " + "\n  ".join(skipped))
