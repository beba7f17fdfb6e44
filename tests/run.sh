#!/usr/bin/env bash
# Every check of the project: lint, Rust tests, Python tests. Run from anywhere after
# `pip install ".[test]"` (the installed package is what pytest imports).
# The benchmark harness smoke test (pytest marker `bench`) is deselected by default; run it
# with `python -m pytest -q -m bench tests/test_benches.py` (.ci/run does, after this).
# Hypothesis examples are random unless CI is set (then derandomized; see tests/conftest.py).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy -D warnings"
cargo clippy --workspace --all-targets --quiet -- -D warnings
echo "== ruff"
python -m ruff check python tests benches docs
echo "== mypy (every definition typed: [tool.mypy] in pyproject.toml)"
python -m mypy python/splitlf
echo "== stubtest (the .pyi stub matches the native module)"
python -m mypy.stubtest splitlf._native
echo "== cargo test (core)"
cargo test -p splitlf-core --quiet
echo "== pytest"
python -m pytest -q
