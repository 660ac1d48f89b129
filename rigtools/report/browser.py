"""Look at a report the way a user does: in a real headless Chromium (Debian's ``chromium``).

:func:`screenshot_page` loads the page from its file, reads back where every figure was laid out
(the report's own load script writes ``data-rect``), takes a full-page screenshot and returns it
with the figure rectangles, so a test can check that each figure is drawn at its size and is not
blank.
"""

from __future__ import annotations

import html
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--force-device-scale-factor=1",
]
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


class BrowserUnavailable(RuntimeError):
    """No Chromium on this machine."""


def find_chromium() -> str:
    """Path of a Chromium/Chrome executable, or :class:`BrowserUnavailable`."""
    for name in CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    raise BrowserUnavailable(
        "no chromium on PATH: install Debian's package 'chromium' "
        "(.ci/run does) to check reports in a real browser"
    )


@dataclass(frozen=True)
class FigureBox:
    """Where a figure was laid out (CSS px), the size it was made at, and its ``alt`` text and
    ``caption`` (its ``figcaption``) as the browser's DOM holds them."""

    left: float
    top: float
    width: float
    height: float
    natural_width: int
    natural_height: int
    loaded: bool
    alt: str = ""
    caption: str = ""


@dataclass
class PageShot:
    """A full-page screenshot (``image``: height x width x 3 floats 0..1), the figures on it and
    the page's DOM after load as the browser serialises it (``dom``: what a test reads the
    tables and text from)."""

    image: np.ndarray
    figures: list[FigureBox]
    page_height: int
    dom: str = ""

    def crop(self, box: FigureBox) -> np.ndarray:
        l, t = round(box.left), round(box.top)
        return self.image[t : t + round(box.height), l : l + round(box.width)]


def _run(args: list[str], timeout: float) -> str:
    proc = subprocess.run(args, capture_output=True, text=True, timeout=timeout, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"chromium failed ({proc.returncode}): {proc.stderr.strip()[-300:]}")
    return proc.stdout


def screenshot_page(page: str | Path, width: int = 1300, timeout: float = 60.0) -> PageShot:
    """Open ``page`` (an HTML file) in headless Chromium; its screenshot and figure boxes."""
    from matplotlib import image as mpimg

    exe = find_chromium()
    url = Path(page).resolve().as_uri()
    with tempfile.TemporaryDirectory(prefix="rig-chromium-") as tmp:
        profile = ["--user-data-dir=" + str(Path(tmp) / "profile")]
        dom = _run([exe, *FLAGS, *profile, f"--window-size={width},1000", "--dump-dom", url], timeout)
        m = re.search(r'data-height="(\d+)"', dom)
        height = int(m.group(1)) if m else 1000
        boxes = []
        # an attribute value may hold ">" (quoted): the tag ends at the first ">" outside quotes
        img = r'(<img\b(?:[^>"]|"[^"]*")*>)(?:\s*<figcaption>(.*?)</figcaption>)?'
        for tag, caption in re.findall(img, dom, re.DOTALL):
            rect = re.search(r'data-rect="([^"]+)"', tag)
            if rect is None:
                continue
            v = rect.group(1).split(",")
            alt = re.search(r'alt="([^"]*)"', tag)
            boxes.append(
                FigureBox(
                    float(v[0]),
                    float(v[1]),
                    float(v[2]),
                    float(v[3]),
                    int(float(v[4])),
                    int(float(v[5])),
                    v[6] == "true",
                    html.unescape(alt.group(1)) if alt else "",
                    html.unescape(caption),
                )
            )
        shot = Path(tmp) / "page.png"
        _run([exe, *FLAGS, *profile, f"--window-size={width},{height}", f"--screenshot={shot}", url], timeout)
        image = mpimg.imread(str(shot))[..., :3]
    return PageShot(image=np.asarray(image, dtype=float), figures=boxes, page_height=height, dom=dom)


def figure_is_drawn(crop: np.ndarray, min_ink: float = 0.01, min_colours: int = 3) -> bool:
    """True if a figure crop is not blank: some share of non-white pixels and several colours."""
    if crop.size == 0:
        return False
    ink = np.mean(np.any(crop < 0.9, axis=-1))
    colours = len(np.unique((crop * 255).astype(np.uint8).reshape(-1, 3), axis=0))
    return bool(ink >= min_ink and colours >= min_colours)
