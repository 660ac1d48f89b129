"""A small, dependency-free HTML report: sections of text, tables and matplotlib figures.

Figures are embedded as base64 PNG with their pixel size in ``width``/``height`` (so the page
lays out before it decodes them, and a browser test can check each figure is drawn at the size it
was made); the page carries its own CSS and needs no network. A short inline script records, after
load, where each figure was laid out (``data-rect``), for the tests' headless-Chromium check
(``tests/headless_chromium.py``).
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from rigtools.derived_files import atomic_write
from rigtools.readable import DIGITS, Shown, number

DPI = 100

CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1280px;
       padding: 1em 2em; color: #1b1b1b; background: #fff; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.8em; }
.sub { color: #555; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f2f2f2; } td.text, th.text { text-align: left; }
caption { caption-side: top; text-align: left; font-weight: 600; padding-bottom: 0.3em; }
figure { margin: 1em 0; } figcaption { color: #333; font-size: 0.92em; max-width: 1200px; }
img { display: block; max-width: none; }
.ok { color: #0a7d28; font-weight: 700; } .bad { color: #b3261e; font-weight: 700; }
.note { background: #f7f7e8; border-left: 4px solid #c9c24a; padding: 0.4em 0.8em; }
"""

SCRIPT = """
window.addEventListener('load', function () {
  document.querySelectorAll('img.figure').forEach(function (img) {
    var r = img.getBoundingClientRect();
    img.setAttribute('data-rect', [r.left + window.scrollX, r.top + window.scrollY, r.width, r.height,
                                   img.naturalWidth, img.naturalHeight, img.complete].join(','));
  });
  document.body.setAttribute('data-height', document.documentElement.scrollHeight);
  document.body.setAttribute('data-width', document.documentElement.scrollWidth);
});
"""


def figure_png(fig: Any, dpi: int = DPI) -> tuple[bytes, int, int]:
    """A matplotlib figure as PNG bytes and its pixel width and height (the figure is closed)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    # cropped to what is drawn: a legend placed below the axes leaves no blank band under it
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight", pad_inches=0.08)
    plt.close(fig)
    data = buf.getvalue()
    width = int.from_bytes(data[16:20], "big")  # PNG IHDR
    height = int.from_bytes(data[20:24], "big")
    return data, width, height


def _cell(value: Any, digits: int) -> tuple[str, bool]:
    """Text of a table cell and whether it is text (left-aligned): numbers as the terminal shows
    them (:func:`rigtools.readable.number`: significant digits, no ``-0``)."""
    if isinstance(value, Shown):
        return str(value), False
    if isinstance(value, bool):
        return ("yes" if value else "no"), True
    if isinstance(value, (float, int)):
        return number(value, None if digits == DIGITS else f".{digits}g"), False
    return ("" if value is None else str(value)), True


@dataclass
class Section:
    """One titled part of the report; add blocks in the order they should appear."""

    title: str
    blocks: list[str] = field(default_factory=list)
    figures: int = 0

    def text(self, text: str) -> Section:
        """A paragraph (plain text, escaped)."""
        self.blocks.append(f"<p>{html.escape(text)}</p>")
        return self

    def note(self, text: str) -> Section:
        """A highlighted remark."""
        self.blocks.append(f'<p class="note">{html.escape(text)}</p>')
        return self

    def table(
        self,
        rows: Sequence[Mapping[str, Any]] | Any,
        caption: str = "",
        columns: Sequence[str] | None = None,
        digits: int = 4,
    ) -> Section:
        """A table from a list of dicts (or a pandas DataFrame); column names should carry units.
        Numbers to ``digits`` significant digits (4: as the terminal shows them); a cell given as
        :class:`rigtools.readable.Shown` is set as it is."""
        if hasattr(rows, "to_dict"):
            rows = rows.to_dict("records")
        rows = list(rows)
        cols = list(columns) if columns is not None else list(dict.fromkeys(k for r in rows for k in r))
        out = ["<table>"]
        if caption:
            out.append(f"<caption>{html.escape(caption)}</caption>")
        out.append("<tr>" + "".join(f"<th>{html.escape(str(c))}</th>" for c in cols) + "</tr>")
        for row in rows:
            cells = []
            for c in cols:
                text, is_text = _cell(row.get(c), digits)
                cells.append(
                    f'<td class="text">{html.escape(text)}</td>'
                    if is_text
                    else f"<td>{html.escape(text)}</td>"
                )
            out.append("<tr>" + "".join(cells) + "</tr>")
        out.append("</table>")
        self.blocks.append("\n".join(out))
        return self

    def figure(self, fig: Any, caption: str, dpi: int = DPI) -> Section:
        """A matplotlib figure, embedded as PNG, with a caption saying what it shows."""
        data, width, height = figure_png(fig, dpi)
        self.figures += 1
        src = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
        self.blocks.append(
            f'<figure><img class="figure" src="{src}" width="{width}" height="{height}" '
            f'alt="{html.escape(caption)}" data-expected="{width},{height}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
        return self

    def html(self) -> str:
        return f"<section><h2>{html.escape(self.title)}</h2>\n" + "\n".join(self.blocks) + "</section>"


@dataclass
class Report:
    """A report: a title, a subtitle line and sections."""

    title: str
    subtitle: str = ""
    sections: list[Section] = field(default_factory=list)

    def section(self, title: str) -> Section:
        """A new section at the end of the report."""
        s = Section(title)
        self.sections.append(s)
        return s

    @property
    def n_figures(self) -> int:
        return sum(s.figures for s in self.sections)

    def html(self) -> str:
        """The whole page."""
        made = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
        sub = html.escape(self.subtitle + (" · " if self.subtitle else "") + f"made {made}")
        body = "\n".join(s.html() for s in self.sections)
        return (
            f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(self.title)}</title><style>{CSS}</style></head>\n"
            f'<body><h1>{html.escape(self.title)}</h1><p class="sub">{sub}</p>\n{body}\n'
            f"<script>{SCRIPT}</script></body></html>\n"
        )


def write_report(report: Report, path: str | Path) -> Path:
    """Write the report's page to ``path`` (UTF-8); returns the path."""
    text = report.html()
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
