#!/usr/bin/env bash
# Every check of the project, in two tiers. Run from anywhere after `pip install ".[test]"`
# (the installed package is what pytest imports).
#
#   bash tests/run.sh            lint, Rust tests, the Python tests but the slow tier
#                                (about 5 minutes on 2 cores once built)
#   bash tests/run.sh --slow     the slow tier only: the long studies and Monte-Carlo
#                                accuracy runs (pytest marker `slow`; tests/conftest.py)
#   bash tests/run.sh --all      both
#
# Any other argument goes to pytest (e.g. `bash tests/run.sh -k render -x`).
# The benchmark harness smoke test (marker `bench`) is deselected in every tier; run it with
# `python -m pytest -q -m bench tests/test_benches.py` (.ci/run does).
# Hypothesis examples are random unless CI is set (then derandomized; see tests/conftest.py).
set -euo pipefail
cd "$(dirname "$0")/.."

tier=fast
args=()
for a in "$@"; do
    case "$a" in
        --slow) tier=slow ;;
        --all) tier=all ;;
        *) args+=("$a") ;;
    esac
done

if [ "$tier" != slow ]; then
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
fi
case "$tier" in
    fast) marks="not bench and not slow" ;;
    slow) marks="slow and not bench" ;;
    all) marks="not bench" ;;
esac
# Say which splitlf is under test: the one `python` imports, which in a dev checkout may be
# an older install (another interpreter first on PATH) rather than this tree's.
echo "== testing $(python -c 'import splitlf, sys; print(splitlf.__file__, "with", sys.executable)')"
echo "== pytest -m '$marks'"
python -m pytest -q -m "$marks" ${args[@]+"${args[@]}"}
