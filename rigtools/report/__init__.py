"""The HTML report: one self-contained page (figures embedded as PNG, works offline, opens from a
file) with the tables and figures of ``rig analyze`` and ``rig compare``."""

from rigtools.report.html import Report, Section, write_report

__all__ = ["Report", "Section", "write_report"]
