"""The fit command's smaller target for long records whose blocks grow after each load change
(``grown_samples`` of creepcomp.fit.reduce)."""

import numpy as np

from creepcomp.fit.data import BLOCK_SAMPLES
from creepcomp.fit.reduce import read_reduced, reduce_record
from creepcomp.io.records import Record, read_record, write_record


def step_record(n: int) -> Record:
    t = np.arange(n) * 0.1
    load = np.where(t >= 30.0, 1.0, 0.0)
    signal = load * (1.0 + 0.03 * -np.expm1(-np.clip(t - 30.0, 0.0, None) / 90.0))
    return Record(t, load, signal + np.random.default_rng(0).normal(0.0, 1e-4, n))


def test_growing_blocks_take_the_smaller_target_and_equal_blocks_keep_theirs():
    long = step_record(300_000)        # blocks of 15 at 20,000: they grow
    grown, note = reduce_record(long, 50_000, grown_samples=20_000)
    want, want_note = reduce_record(long, 20_000)
    assert len(grown) <= 20_000 and BLOCK_SAMPLES in grown.metadata and note == want_note
    np.testing.assert_array_equal(grown.signal, want.signal)
    middle = step_record(100_000)      # blocks of 6 at 20,000 would be equal: 50,000 holds
    kept, kept_note = reduce_record(middle, 50_000, grown_samples=20_000)
    plain, plain_note = reduce_record(middle, 50_000)
    assert len(kept) > 20_000 and kept_note == plain_note
    np.testing.assert_array_equal(kept.signal, plain.signal)


def test_the_smaller_target_is_the_same_read_in_pieces_or_whole(tmp_path):
    path = write_record(tmp_path / "long.csv", step_record(60_000))
    want, want_note = reduce_record(read_record(path), 5_000, grown_samples=1_000)
    assert BLOCK_SAMPLES in want.metadata and len(want) <= 1_000
    [(got, note)] = read_reduced(path, (5_000,), block_bytes=16_384, grown_samples=1_000)
    assert note == want_note and got.metadata == want.metadata
    np.testing.assert_allclose(got.signal, want.signal, rtol=1e-13, atol=1e-13)
