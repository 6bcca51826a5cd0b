"""The b-bit search's sort (``rate_rows.offset_order`` and its ``merge_order``): the stable order
of the element offsets, whatever their spread (the search's breakpoints are passed in this order,
so a wrong or unstable order changes the phases found)."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.model.rate_rows import _INSERTION_MAX, merge_order, offset_order


def _offsets(kind: str, m: int, rng: np.random.Generator) -> np.ndarray:
    if kind == "spread":  # element phases: buckets of about one
        return rng.uniform(0.0, 1.0, m)
    if kind == "clustered":  # most offsets in one bucket: larger than _INSERTION_MAX, merge-sorted
        out = min(5, m)
        return np.concatenate([rng.uniform(0.40, 0.401, m - out), rng.uniform(0.0, 1.0, out)])
    return rng.integers(0, 4, m) / 4.0  # ties: four values, the order by index within each


@pytest.mark.parametrize("kind", ["spread", "clustered", "ties"])
@pytest.mark.parametrize("m", [1, 2, 7, 33, 100, 257])
def test_offset_order_is_the_stable_argsort(kind: str, m: int) -> None:
    offset = _offsets(kind, m, np.random.default_rng(m))
    padded = np.concatenate([offset, [9.0, -9.0]])  # only offset[:m] is read
    np.testing.assert_array_equal(offset_order(padded, m, 1.0), np.argsort(offset, kind="stable"))


def test_a_clustered_bucket_goes_through_the_merge() -> None:
    offset = _offsets("clustered", 100, np.random.default_rng(0))
    sizes = np.bincount(np.minimum((offset * 100).astype(int), 99), minlength=100)
    assert sizes.max() > _INSERTION_MAX  # the case above is the merge sort's, not the insertion's


@pytest.mark.parametrize("n", [0, 1, 2, 3, 5, 8, 31, 64, 100])
def test_merge_order_sorts_any_subset_stably(n: int) -> None:
    rng = np.random.default_rng(n)
    offset = np.round(rng.uniform(0.0, 1.0, 200), 1)  # many ties
    part = np.sort(rng.choice(200, n, replace=False)).astype(np.int64)
    np.testing.assert_array_equal(merge_order(part, offset), part[np.argsort(offset[part], kind="stable")])
