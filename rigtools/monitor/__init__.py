"""The live view of a recording: ``rig monitor FILE`` and ``rig acquire ... --monitor``.

A read-only follower of a recording being written (or finished), served as a Bokeh page on the
loopback address by default: time traces (min/max envelopes), the amplitude spectrum with its
k·fe harmonics, the force-control state, impacts per period, peaks against the safety limits,
the points of a study and the status.

- :mod:`.envelope`: decimation that keeps every spike;
- :mod:`.follow`: :class:`~.follow.Follower` and :class:`~.follow.Snapshot`, the data logic;
- :mod:`.page`: the Bokeh document;
- :mod:`.server`: :func:`~.server.serve`, the token and the stop control;
- :mod:`.control_files`: the stop request and live status files beside the recording;
- :mod:`.beside`: starting a monitor beside ``rig acquire``.
"""
