"""COCO RLE written with numpy: exact round trips and COCO's string encoding."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from synth.masks import bbox_of, decode_counts, decode_mask, encode_counts, encode_mask, mask_from_runs, runs_from_mask


@settings(max_examples=80, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12))))
def test_mask_round_trip(mask):
    rle = encode_mask(mask)
    assert rle["size"] == list(mask.shape)
    np.testing.assert_array_equal(decode_mask(rle), mask)
    assert sum(runs_from_mask(mask)) == mask.size


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(0, 100_000), min_size=1, max_size=30))
def test_counts_string_round_trip(runs):
    assert decode_counts(encode_counts(runs)) == runs


@pytest.mark.parametrize(
    "mask, runs",
    [
        (np.zeros((2, 2), bool), [4]),
        (np.ones((2, 2), bool), [0, 4]),
        # column-major: column 0 = (0, 1), column 1 = (1, 1)
        (np.array([[0, 1], [1, 1]], bool), [1, 3]),
        (np.array([[1, 0, 0], [0, 0, 1]], bool), [0, 1, 4, 1]),
    ],
)
def test_runs_are_column_major_and_start_with_zeros(mask, runs):
    assert runs_from_mask(mask) == runs
    np.testing.assert_array_equal(mask_from_runs(runs, *mask.shape), mask)


@pytest.mark.parametrize(
    "runs, counts",
    [
        ([4], "4"),  # 4 -> one 5-bit group 0b00100 -> chr(48 + 4)
        ([0, 4], "04"),
        ([40], "X1"),  # 40 = 8 + 1*32: groups 8 (with continuation 0x20) then 1 -> chr(88) chr(49)
        ([5, 3, 2], "532"),
        ([5, 3, 2, 1], "532N"),  # 4th run stored as 1 - 3 = -2 -> 0b11110 (sign bit set) -> chr(48 + 30)
    ],
)
def test_coco_string_encoding(runs, counts):
    assert encode_counts(runs) == counts
    assert decode_counts(counts) == runs


def test_bbox_is_coco_xywh():
    mask = np.zeros((6, 8), bool)
    mask[2:5, 3:7] = True
    assert bbox_of(mask) == [3, 2, 4, 3]


def test_bad_runs_are_rejected():
    with pytest.raises(ValueError, match="counts"):
        mask_from_runs([1, 2], 2, 2)
