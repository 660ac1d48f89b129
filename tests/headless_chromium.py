"""A headless Chromium (Debian's ``chromium``) for the tests and benchmarks that look at what a
user sees; no ``rig`` command needs a browser, so this lives beside the tests, not in the library.

Two ways in, one executable and one set of flags (:func:`find_chromium`, :data:`FLAGS`):

- a report (a static page): :func:`screenshot_page` loads the page from its file, reads back where
  every figure was laid out (the report's own load script writes ``data-rect``), takes a full-page
  screenshot and returns it with the figure rectangles, so a test can check that each figure is
  drawn at its size and is not blank (:func:`figure_is_drawn`);
- the live monitor (a websocket page a one-shot ``--screenshot`` cannot wait for):
  :class:`Chromium` starts the browser with a DevTools port, opens pages and lets a test or a
  benchmark read values off a page (the page's ids, inside Bokeh's shadow DOM) and take
  screenshots. The protocol is spoken over tornado's websocket client (Bokeh's own dependency).

Tests get it on ``sys.path`` from ``tests/conftest.py``'s folder; benchmarks add ``tests/``.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import html
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import numpy as np
from matplotlib import image as mpimg
from tornado.websocket import websocket_connect

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
        "(.ci/run does) to check reports and the monitor in a real browser"
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


# -- a live page over the DevTools protocol -------------------------------------------------
#: JavaScript: the text of the element with id ``ID``, searched through every shadow root.
_FIND = """
(() => {
  const find = (root, id) => {
    const hit = root.getElementById ? root.getElementById(id) : null;
    if (hit) return hit;
    for (const n of root.querySelectorAll('*')) {
      if (n.shadowRoot) { const r = find(n.shadowRoot, id); if (r) return r; }
    }
    return null;
  };
  const out = {};
  for (const id of IDS) { const el = find(document, id); out[id] = el ? el.textContent : null; }
  return JSON.stringify(out);
})()
"""


class Page:
    """One open tab: :meth:`texts` of elements by id, :meth:`screenshot`, :meth:`click_button`."""

    def __init__(self, browser: Chromium, ws: Any) -> None:
        self._browser, self._ws, self._ids = browser, ws, itertools.count(1)

    def call(self, method: str, **params: Any) -> dict:
        return self._browser.loop.run_until_complete(self._call(method, params))

    async def _call(self, method: str, params: dict) -> dict:
        msg_id = next(self._ids)
        await self._ws.write_message(json.dumps({"id": msg_id, "method": method, "params": params}))
        while True:
            raw = await self._ws.read_message()
            if raw is None:
                raise RuntimeError("the browser closed the page")
            msg = json.loads(raw)
            if msg.get("id") == msg_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    def evaluate(self, expression: str) -> Any:
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result.get("result", {}).get("value")

    def texts(self, *ids: str) -> dict[str, str | None]:
        """Text of the elements with these ids (None where there is none yet)."""
        return json.loads(self.evaluate(_FIND.replace("IDS", json.dumps(list(ids)))))

    def wait_text(self, element_id: str, timeout: float = 30.0, pattern: str = r".") -> str:
        """Wait until element ``element_id`` shows text matching ``pattern``; return it."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            text = self.texts(element_id)[element_id]
            if text is not None and re.search(pattern, text):
                return text
            time.sleep(0.05)
        raise TimeoutError(f"#{element_id} did not show {pattern!r} within {timeout} s")

    def click_button(self, label: str) -> bool:
        """Click the first button whose text contains ``label`` (through shadow roots)."""
        js = """
        (() => { const walk = (root) => { for (const n of root.querySelectorAll('*')) {
            if (n.tagName === 'BUTTON' && n.textContent.includes(LABEL)) { n.click(); return true; }
            if (n.shadowRoot && walk(n.shadowRoot)) return true; } return false; };
          return walk(document); })()
        """
        return bool(self.evaluate(js.replace("LABEL", json.dumps(label))))

    def screenshot(self, path: str | Path) -> Path:
        data = self.call("Page.captureScreenshot", format="png")["data"]
        Path(path).write_bytes(base64.b64decode(data))
        return Path(path)


class Chromium:
    """A headless Chromium with a DevTools port (a live page); use as a context manager."""

    def __init__(self, exe: str | None = None, width: int = 1500, height: int = 1150) -> None:
        self.exe = exe or find_chromium()
        self.size = (width, height)
        self.loop = asyncio.new_event_loop()
        self._profile = tempfile.mkdtemp(prefix="rig-cdp-")
        self._proc: subprocess.Popen | None = None
        self.port = 0

    def __enter__(self) -> Self:
        args = [
            self.exe,
            *FLAGS,
            f"--user-data-dir={self._profile}",
            f"--window-size={self.size[0]},{self.size[1]}",
        ]
        args += ["--remote-debugging-port=0", "about:blank"]
        # its own session: close() ends Chromium's helper processes with it
        self._proc = subprocess.Popen(
            args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True
        )
        assert self._proc.stderr is not None
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            line = self._proc.stderr.readline()
            m = re.search(r"DevTools listening on ws://[^:]+:(\d+)/", line)
            if m:
                self.port = int(m.group(1))
                break
            if not line and self._proc.poll() is not None:
                break
        if not self.port:
            self.close()
            raise RuntimeError("chromium did not open its DevTools port")
        return self

    def open(self, url: str) -> Page:
        """A new tab showing ``url``."""
        req = urllib.request.Request(f"http://127.0.0.1:{self.port}/json/new?{url}", method="PUT")
        with urllib.request.urlopen(req, timeout=10) as resp:
            target = json.loads(resp.read())

        async def connect() -> Any:
            return await websocket_connect(target["webSocketDebuggerUrl"], max_message_size=1 << 28)

        ws = self.loop.run_until_complete(connect())
        page = Page(self, ws)
        page.call("Page.enable")
        return page

    def close(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        if self._proc is not None:
            # helpers (crashpad, zygote) may outlive the browser and still write into the profile,
            # which made removing it fail now and then ("Directory not empty")
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self._proc.pid, signal.SIGKILL)
        for attempt in range(20):
            try:
                shutil.rmtree(self._profile)
                break
            except FileNotFoundError:
                break
            except OSError:
                if attempt == 19:
                    raise
                time.sleep(0.1)
        self.loop.close()

    def __exit__(self, *exc: object) -> None:
        self.close()
