"""The seed's published numbers do not move (issue 20): the table of tests/seed_table.py,
pinned from the two-engine code in tests/data/seed_pinned.json, agrees to 1e-12 relative
with what the one engine computes for ``Camera.paper()`` and ``Design.preset("seed")``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from seed_table import PINNED, table

import splitlf


def _compare(got, want, where: str) -> None:
    if isinstance(want, dict):
        assert set(got) == set(want), where
        for k in want:
            _compare(got[k], want[k], f"{where}.{k}")
        return
    g = np.array(got, dtype=float)  # None (an infinite value) becomes nan
    w = np.array(want, dtype=float)
    assert g.shape == w.shape, where
    assert np.array_equal(np.isnan(g), np.isnan(w)), where
    ok = ~np.isnan(w)
    scale = np.max(np.abs(w[ok]), initial=0.0)
    np.testing.assert_allclose(g[ok], w[ok], rtol=1e-12, atol=1e-12 * scale, err_msg=where)


@pytest.mark.parametrize("make", [splitlf.Camera.paper, lambda: splitlf.Design.preset("seed")],
                         ids=["Camera.paper", "Design.preset"])
def test_seed_table_agrees_with_the_pinned_one(make):
    want = json.loads(PINNED.read_text(encoding="utf-8"))
    got = json.loads(json.dumps(table(make(), "channel 1", "channel 2", "union")))
    _compare(got, want, "seed")
