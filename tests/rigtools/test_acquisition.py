"""The block loop against a small in-test device that plays the drive through a known system
(channel 0: 2 x drive delayed by 3 samples; channel 1: a constant 1.5), so every stored sample
has an exact expected value."""

import numpy as np
import pytest
from scipy import signal

from rigtools.acquisition import (
    AcquisitionAborted,
    BlockCollector,
    BlockStream,
    RandomDrive,
    acquire,
)
from rigtools.drivers.contracts import (
    AcquisitionDevice,
    InputChannelSpec,
    InputOverflow,
    OutputChannelSpec,
    OutputUnderflow,
)
from rigtools.drivers.safety import ChannelLimit, SafetyMonitor, SineDrive

FS, BLOCK, DELAY, GAIN = 1000.0, 100, 3, 2.0


class DelayDevice(AcquisitionDevice):
    """Plays the written drive; reads back GAIN x drive delayed by DELAY samples, and 1.5."""

    backend = "test"

    def __init__(self, fault_at_block: int | None = None):
        self.fault_at_block = fault_at_block
        self.written = []  # every drive block written
        self.played = np.zeros(0)  # drive samples consumed by reads
        self._queue = np.zeros(0)
        self._running = False
        self.stops = 0
        self.reads = 0

    def configure(self, inputs, output, sample_rate, block_size=None):
        self._inputs = tuple(inputs)
        return sample_rate

    sample_rate = property(lambda self: FS)
    block_size = property(lambda self: BLOCK)
    input_channels = property(lambda self: self._inputs)
    running = property(lambda self: self._running)

    def input_to_output_delay(self):
        return DELAY / FS

    def write(self, drive):
        self.written.append(np.array(drive))
        self._queue = np.concatenate([self._queue, drive])

    def start(self):
        self._running = True

    def read(self, n_samples=None, timeout=10.0):
        n = n_samples or BLOCK
        if self._queue.size < n:
            self.stop()
            raise OutputUnderflow("test device ran out of drive")
        drive, self._queue = self._queue[:n], self._queue[n:]
        k0 = self.played.size
        self.played = np.concatenate([self.played, drive])
        padded = np.concatenate([np.zeros(DELAY), self.played])
        out = np.vstack([GAIN * padded[k0 : k0 + n], np.full(n, 1.5)])
        self.reads += 1
        if self.fault_at_block is not None and self.reads - 1 == self.fault_at_block:
            self.stop()
            raise InputOverflow("test overflow", partial=out[:, :40])
        return out

    def stop(self):
        if self._running:
            self.stops += 1
        self._running = False
        self._queue = np.zeros(0)

    def close(self):
        self.stop()


def _device(**kw):
    dev = DelayDevice(**kw)
    dev.configure(
        [
            InputChannelSpec("force", "x/ai0", "force", 11.24, "mV/N"),
            InputChannelSpec("level", "x/ai1", "voltage"),
        ],
        OutputChannelSpec(),
        FS,
    )
    return dev


def _sine(amplitude=1.0):
    drive = SineDrive(FS, 37.0, max_drive=5.0, ramp_time=0.2)
    drive.set_target(amplitude)
    return drive


def test_acquire_stores_every_block_exactly_and_ends_at_zero():
    dev, sink = _device(), BlockCollector()
    stats = acquire(dev, _sine(), 1.0, sink=sink, record_drive=True)
    data = sink.data
    # 10 blocks + the 2 queued + ramp (0.2 s = 2 blocks) and delay (3 samples -> 1 block)
    assert stats.blocks == 10 + 2 + 3 and data.shape == (3, stats.samples)
    played = dev.played[: data.shape[1]]
    np.testing.assert_array_equal(data[2], played)  # drive row = played drive
    np.testing.assert_allclose(data[0, DELAY:], GAIN * played[:-DELAY], rtol=0, atol=1e-12)
    assert np.all(data[1] == 1.5)
    assert abs(played[-1]) == 0.0 and np.max(np.abs(played[-DELAY - 1 :])) == 0.0
    assert np.max(np.abs(played)) == pytest.approx(1.0, abs=1e-3)  # ramped up to 1 V
    assert dev.stops == 1 and not dev.running


def test_fault_keeps_blocks_and_partial_and_names_the_fault():
    dev, sink = _device(fault_at_block=4), BlockCollector()
    with pytest.raises(AcquisitionAborted, match="input overflow: test overflow") as info:
        acquire(dev, _sine(), 2.0, sink=sink)
    assert info.value.fault == "input overflow"
    assert isinstance(info.value.cause, InputOverflow)
    assert info.value.samples_kept == 4 * BLOCK + 40 == sink.data.shape[1]
    np.testing.assert_allclose(sink.data[0, DELAY:], GAIN * dev.played[: 4 * BLOCK + 40 - DELAY], atol=1e-12)
    assert dev.stops == 1 and not dev.running


def test_safety_abort_stops_and_keeps_the_offending_block():
    dev, sink = _device(), BlockCollector()
    monitor = SafetyMonitor([ChannelLimit("force", 2.0, 3.0)], dev.input_channels, max_drive=5.0)
    with pytest.raises(AcquisitionAborted, match="force peak .* abort limit 3") as info:
        acquire(dev, _sine(2.0), 3.0, sink=sink, safety=monitor)  # 2 x 2 V = 4 N > 3 N
    assert info.value.fault == "safety abort"
    assert np.max(np.abs(sink.data[0])) >= 3.0  # the block that tripped is kept
    assert np.max(np.abs(sink.data[0, :-BLOCK])) < 3.0
    assert dev.stops == 1


def test_warnings_are_collected_without_stopping():
    dev = _device()
    monitor = SafetyMonitor([ChannelLimit("force", 1.5, 3.0)], dev.input_channels, max_drive=5.0)
    stats = acquire(dev, _sine(1.0), 1.0, safety=monitor)
    assert stats.warnings and {w.channel for w in stats.warnings} == {"force"}


def test_sink_error_and_ctrl_c_stop_the_device():
    class FailingSink(BlockCollector):
        def append(self, block):
            if len(self.blocks) == 3:
                raise OSError("disk full")
            super().append(block)

    dev, sink = _device(), FailingSink()
    with pytest.raises(AcquisitionAborted, match="OSError|disk full") as info:
        acquire(dev, _sine(), 2.0, sink=sink)
    assert info.value.samples_kept == 3 * BLOCK and dev.stops == 1

    dev = _device()

    def interrupt(block, stats):
        if stats.blocks == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        acquire(dev, _sine(), 2.0, on_block=interrupt)
    assert dev.stops == 1 and not dev.running


def test_block_stream_for_procedures_switches_sinks():
    dev, first, second = _device(), BlockCollector(), BlockCollector()
    drive = _sine()
    with BlockStream(dev, drive, sink=first) as stream:
        while not drive.settled or stream.stats.blocks < 3:
            stream.read()
        stream.sink = second
        for _ in range(4):
            stream.read()
        stream.finish()
    assert first.data.shape[1] == 3 * BLOCK and second.data.shape[1] >= 4 * BLOCK


def test_random_drive_rms_band_and_bursts():
    """Continuous: RMS within 2 % of target (60 s of noise: sampling error ~0.5 %), > 99 % of the
    power within an octave of the band. Burst: zero in the off part, never above max_drive, ends at 0 V."""
    fs = 4000.0
    drive = RandomDrive(fs, 0.5, (50.0, 500.0), max_drive=2.5, ramp_time=0.01, seed=3)
    x = np.concatenate([drive.next_block(4000) for _ in range(60)])[400:]
    assert np.std(x) == pytest.approx(0.5, rel=0.02)
    f, p = signal.welch(x, fs, nperseg=4000)
    inside = (f >= 25) & (f <= 1000)  # 4th-order skirts: an octave beyond the band
    assert p[inside].sum() / p.sum() > 0.99
    burst = RandomDrive(
        fs, 1.0, (50.0, 500.0), max_drive=2.5, ramp_time=0.001, burst_period=0.5, burst_fraction=0.6, seed=4
    )
    y = np.concatenate([burst.next_block(1000) for _ in range(8)]).reshape(-1, 2000)
    assert np.all(y[:, 1200:] == 0.0) and np.std(y[1:, 50:1150]) > 0.8
    assert np.max(np.abs(y)) <= 2.5
    assert burst.stop_block()[-1] == 0.0


def test_random_drive_ramp_is_the_raised_cosine_envelope():
    """Same seed, same filter: the ramped noise divided by the (1-sample ramp) full-level noise is
    the raised cosine a(k) = (1 - cos(pi k / n)) / 2, k = 1..n, then 1; to 1e-12 (round-off)."""
    fs, n = 4000.0, 400
    ramped = RandomDrive(fs, 0.5, (50.0, 500.0), max_drive=50.0, ramp_time=n / fs, seed=11)
    full = RandomDrive(fs, 0.5, (50.0, 500.0), max_drive=50.0, ramp_time=1 / fs, seed=11)
    x = np.concatenate([ramped.next_block(s) for s in (150, 1, 449)])
    y = full.next_block(600)
    k = np.arange(1, 601)
    envelope = np.where(k <= n, 0.5 * (1 - np.cos(np.pi * k / n)), 1.0)
    np.testing.assert_allclose(x, envelope * y, rtol=1e-12, atol=1e-15)
    assert ramped.settled and full.settled
    with pytest.raises(ValueError, match="rms 9.0 V is outside 0..2.5 V"):
        RandomDrive(fs, 0.5, (50.0, 500.0), max_drive=2.5).set_target(9.0)
