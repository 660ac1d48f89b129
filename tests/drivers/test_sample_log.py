"""The simulated rig's sample records: the latest samples read without joining the whole record
are the whole record's last samples, and the record keeps what it promises."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.drivers.sample_log import SampleLog


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.integers(0, 40), min_size=0, max_size=25),
    keep=st.integers(1, 120),
    rows=st.sampled_from([(), (2,)]),
    data=st.data(),
)
def test_tail_is_the_last_samples_of_the_whole_record(sizes, keep, rows, data):
    log = SampleLog(rows)
    stream = []
    count = 0
    for n in sizes:
        block = np.arange(count, count + n, dtype=float) * np.ones((*rows, 1))
        count += n
        stream.append(block)
        log.append(block, keep)
        whole = log.array()
        # the record is the stream's latest samples, at least `keep` of them (or all there were)
        assert whole.shape == (*rows, log.held)
        assert log.held >= min(keep, count)
        assert np.array_equal(whole[..., -1:], block[..., -1:]) or n == 0
        assert np.array_equal(
            whole, np.concatenate([*stream, np.zeros((*rows, 0))], axis=-1)[..., count - log.held :]
        )
        k = data.draw(st.integers(0, log.held))
        assert np.array_equal(log.tail(k), whole[..., log.held - k :])


def test_more_than_held_is_refused():
    log = SampleLog()
    log.append(np.ones(5), keep=10)
    with pytest.raises(ValueError, match="6 samples asked for, 5 held"):
        log.tail(6)
    assert log.tail(0).shape == (0,)
