"""Where the procedures have imported :class:`~rigtools.controlled_point.ControlledPoint` from.

Its home is :mod:`rigtools.controlled_point` (outside this package, so the report and the monitor
read controlled points without importing every procedure); the PLL and CBC procedures still import
it from here until their next change.
"""

from rigtools.controlled_point import ControlledPoint

__all__ = ["ControlledPoint"]
