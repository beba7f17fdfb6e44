"""Smoke test of the benchmark harness at --quick sizes (no timing assertions): it must run,
find NumPy and native results equal, and write its JSON and Markdown reports."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

BENCHES = Path(__file__).resolve().parent.parent / "benches"


def test_quick_benchmarks_run(tmp_path):
    subprocess.run([sys.executable, str(BENCHES / "run.py"), "--quick", "--rounds", "1",
                    "--out", str(tmp_path)], check=True, capture_output=True, text=True)
    doc = json.loads((tmp_path / "results.json").read_text())
    names = [r["workload"] for r in doc["results"]]
    assert "W1" in names and doc["quick"] is True
    for r in doc["results"]:
        assert all(t > 0 for t in r["median_s"].values())
    table = (tmp_path / "RESULTS.md").read_text()
    assert table.count("\n| W") == len(names)
