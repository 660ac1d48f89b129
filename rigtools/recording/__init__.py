"""HDF5 recordings of rig runs (schema v1): streaming writer, lazy reader, validation.

See ``docs/recording-format.md`` for the file layout.

>>> from rigtools.recording import RecordingWriter, ChannelSpec, open_recording, RecordingError
>>> spec = ChannelSpec("force", "N", "force", 51200.0)
>>> with RecordingWriter("run.h5", backend="simulated", rig="{}", experiment={}) as rec:
...     point = rec.begin_point({"fe": 60.0}, [spec])
...     point.append([[0.0, 0.5, 1.0, 0.5]])  # one block: a row per channel
...     point.end()
>>> with open_recording("run.h5") as run:
...     run.status, run.points[0].channels["force"].units, len(run.points[0].channels["force"])
('complete', 'N', 4)
>>> try:
...     open_recording("missing.h5")
... except RecordingError as exc:  # one line, for the user
...     print(exc)
missing.h5: no such file
"""

from rigtools.recording.lock import writer_alive
from rigtools.recording.reader import Channel, Point, Recording, open_recording, reading_damaged
from rigtools.recording.schema import (
    SCHEMA_NAME,
    SCHEMA_VERSION,
    ChannelSpec,
    RecordingError,
    RecordingWriteError,
)
from rigtools.recording.validate import CheckResult, Problem, check_recording
from rigtools.recording.writer import PointWriter, RecordingWriter

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "Channel",
    "ChannelSpec",
    "CheckResult",
    "Point",
    "PointWriter",
    "Problem",
    "Recording",
    "RecordingError",
    "RecordingWriteError",
    "RecordingWriter",
    "check_recording",
    "open_recording",
    "reading_damaged",
    "writer_alive",
]
