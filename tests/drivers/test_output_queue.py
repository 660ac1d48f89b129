"""The output queue bound (0.1 s from a fault to 0 V, queued drive included) on the simulated
rig, which models the NI backend's non-regenerating output, and the simulated rig's memory."""

import numpy as np
import pytest

from rigtools.acquisition import AcquisitionAborted, BlockCollector, acquire, stream_piece
from rigtools.config import load_rig
from rigtools.drivers.contracts import LimitExceeded
from rigtools.drivers.drive_signals import SineDrive
from rigtools.drivers.safety import output_queue_limit
from rigtools.drivers.simulated import Fault, SimulatedRig

FS = 51200.0


@pytest.fixture(scope="module")
def cfg():
    return load_rig()


def _rig(cfg, **kw):
    rig = SimulatedRig.from_config(cfg, seed=1, model="linear", **kw)
    rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), FS, cfg.daq.block_size())
    return rig


def test_queue_limit_closed_form():
    # (0.1 - 0.05) s * 0.9 * 51200 S/s
    assert output_queue_limit(FS, 0.05) == 2304
    # a 100 ms ramp keeps 25 ms for the queue
    assert output_queue_limit(FS, 0.1) in (1151, 1152)  # floor of 1152 - round-off


def test_stream_pieces_keep_two_within_the_limit(cfg):
    rig = _rig(cfg)
    assert rig.output_queue_limit == 2304 and rig.block_size == 5120
    assert stream_piece(rig) == 1024 and 2 * stream_piece(rig) <= rig.output_queue_limit
    with pytest.raises(LimitExceeded, match="output queue limit 2304"):
        rig.write(np.zeros(5120))


@pytest.mark.parametrize("block", [1, 3, 4, 7])
def test_fault_to_zero_drive_within_0_1_s_queue_included(cfg, block):
    """A fault mid-block: the drive that reached the amplifier after the fault (the queued
    pieces, then the raised-cosine ramp from their last sample) is 0 V within 0.1 s."""
    rig = _rig(cfg, faults=[Fault("input_overflow", at_block=block)])
    drive = SineDrive(FS, 60.0, max_drive=5.0, ramp_time=0.05)
    drive.set_target(2.0)
    with pytest.raises(AcquisitionAborted):
        acquire(rig, drive, 1.0, sink=BlockCollector())
    after = rig.drive_log[rig.fault_sample :]
    assert after[-1] == 0.0 and after.size <= int(0.1 * FS)
    last = np.flatnonzero(np.abs(after) > 1e-12)
    assert (last[-1] + 1) / FS <= 0.1


def test_drive_log_memory_stays_bounded(cfg):
    """3 s of drive with a 1 s log: the log holds at most 1 s plus one piece; the count of all
    drive samples is kept."""
    rig = _rig(cfg, drive_log_seconds=1.0)
    drive = SineDrive(FS, 60.0, max_drive=5.0, ramp_time=0.05)
    drive.set_target(1.0)
    acquire(rig, drive, 3.0)
    assert rig.drive_log.size <= FS + stream_piece(rig)
    assert rig.drive_samples >= 3.0 * FS
