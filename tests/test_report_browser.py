"""report.html in a real headless browser: no console errors, no network, the 3D view renders.

Debian's chromium is driven over the DevTools protocol (a websocket on 127.0.0.1): every
uncaught exception, console.error and browser log entry of level "error" is collected, and so
is every request the page makes. A page with a deliberate error proves the collector works.
The screenshot of the 3D view is kept next to the report (``report_3d.png``) to look at.
"""
from __future__ import annotations

import base64
import io
import json
import os
import shutil
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_examples import SMALL_7A  # noqa: E402

websocket = pytest.importorskip("websocket", reason="websocket-client is a test dependency: "
                                "pip install -e '.[test]'")

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  # software WebGL (SwiftShader) without a GPU; chromium no longer falls back to it
                  # silently
                  "--enable-unsafe-swiftshader", "--hide-scrollbars", "--mute-audio",
                  "--window-size=1280,900", "--remote-debugging-address=127.0.0.1",
                  "--remote-debugging-port=0"]


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if path := shutil.which(name):
            return path
    pytest.skip("no chromium on PATH: `make test` installs Debian's chromium when run as root, "
                "else: sudo apt-get install -y chromium")


class Browser:
    """One headless chromium with one page, driven over the DevTools protocol."""

    def __init__(self, user_data_dir: Path, timeout: float = 20.0):
        self.timeout = timeout
        self.proc = subprocess.Popen([_chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={user_data_dir}",
                                      "about:blank"], stdout=subprocess.DEVNULL,
                                     stderr=open(user_data_dir / "chromium.log", "wb"))
        port_file = user_data_dir / "DevToolsActivePort"
        t0 = time.monotonic()
        while not (port_file.exists() and port_file.read_text().count("\n") >= 1):
            if self.proc.poll() is not None or time.monotonic() - t0 > timeout:
                self.close()
                raise RuntimeError("chromium did not start: "
                                   + (user_data_dir / "chromium.log").read_text()[-2000:])
            time.sleep(0.05)
        port = int(port_file.read_text().split()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=timeout) as r:
            page = next(t for t in json.load(r) if t["type"] == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=timeout,
                                              suppress_origin=True)
        self._id = 0
        self.errors: list[str] = []
        self.requests: list[str] = []
        self.events: list[str] = []
        for domain in ("Runtime", "Log", "Page", "Network"):
            self.call(f"{domain}.enable")

    def _event(self, msg: dict) -> None:
        method, p = msg["method"], msg.get("params", {})
        self.events.append(method)
        if method == "Runtime.exceptionThrown":
            d = p["exceptionDetails"]
            self.errors.append("exception: " + d.get("exception", {}).get("description", d["text"]))
        elif method == "Runtime.consoleAPICalled" and p["type"] in ("error", "assert"):
            self.errors.append("console.error: " + " ".join(
                str(a.get("value", a.get("description", ""))) for a in p["args"]))
        elif method == "Log.entryAdded" and p["entry"]["level"] == "error":
            self.errors.append(f"log ({p['entry']['source']}): {p['entry']['text']}")
        elif method == "Network.requestWillBeSent":
            self.requests.append(p["request"]["url"])

    def call(self, method: str, **params):
        self._id += 1
        self.ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self._id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]
            if "method" in msg:
                self._event(msg)

    def evaluate(self, expression: str):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                      awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression!r}: {r['exceptionDetails']['text']}")
        return r["result"].get("value")

    def open(self, url: str, *, ready: str = "true") -> None:
        """Navigate and wait until the page has loaded and the JS expression ``ready`` holds."""
        self.events.clear()
        self.call("Page.navigate", url=url)
        t0 = time.monotonic()
        while time.monotonic() - t0 < self.timeout:
            if "Page.loadEventFired" in self.events and self.evaluate(f"!!({ready})"):
                return
            self.settle(0.1)
        raise TimeoutError(f"{url} not ready ({ready}) after {self.timeout} s; errors: {self.errors}")

    def settle(self, seconds: float) -> None:
        """Let the page run (and collect its events) for a while."""
        t_end = time.monotonic() + seconds
        self.ws.settimeout(0.05)
        try:
            while time.monotonic() < t_end:
                try:
                    self._event(json.loads(self.ws.recv()))
                except websocket.WebSocketTimeoutException:
                    pass
        finally:
            self.ws.settimeout(self.timeout)

    def screenshot(self, selector: str) -> bytes:
        """PNG of the element ``selector`` (scrolled into view)."""
        box = self.evaluate(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                            "e.scrollIntoView(); const r = e.getBoundingClientRect();"
                            "return [r.x + scrollX, r.y + scrollY, r.width, r.height]; })()")
        x, y, w, h = box
        r = self.call("Page.captureScreenshot", format="png", captureBeyondViewport=True,
                      clip=dict(x=x, y=y, width=w, height=h, scale=1))
        return base64.b64decode(r["data"])

    def close(self) -> None:
        try:
            if getattr(self, "ws", None):
                self.ws.close()
        finally:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


#: the module's tests share the quick example's run with test_examples (conftest.small_7a,
#: made once per worker): one xdist worker runs them all (make test's --dist loadgroup)
pytestmark = SMALL_7A


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    b = Browser(tmp_path_factory.mktemp("chromium-profile"))
    yield b
    b.close()


def test_the_pipeline_hands_its_sun_directions_to_the_report(small_7a):
    assert small_7a.report_had_sun


def test_the_collector_catches_console_errors(browser, tmp_path):
    """A page with a deliberate error: the test would see one in report.html too."""
    bad = tmp_path / "bad.html"
    bad.write_text("<!doctype html><meta charset='utf-8'><body><p>bad page</p>"
                   "<img src='no-such-figure.png' alt='missing'><script>"
                   "console.error('deliberate console.error');"
                   "setTimeout(() => { undefinedFunctionOfTheTest(); }, 0);"
                   "</script></body>")
    browser.errors.clear()
    browser.open(bad.as_uri())
    browser.settle(0.3)
    assert any("deliberate console.error" in e for e in browser.errors), browser.errors
    assert any("undefinedFunctionOfTheTest" in e for e in browser.errors), browser.errors
    assert any(e.startswith("log (network)") for e in browser.errors), browser.errors  # the <img>


def _hue_share(png: bytes, hex_colour: str, tol: int = 6) -> float:
    """Share of the picture's pixels with the hue of ``hex_colour`` (any shade of it)."""
    from PIL import Image

    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV"), dtype=int)
    ref = np.asarray(Image.new("RGB", (1, 1), hex_colour).convert("HSV"), dtype=int)[0, 0]
    dh = np.abs(hsv[..., 0] - ref[0])
    dh = np.minimum(dh, 256 - dh)
    return float(((dh <= tol) & (hsv[..., 1] > 90) & (hsv[..., 2] > 40)).mean())


def test_report_renders_the_3d_view_with_no_errors(browser, small_7a):
    """Example 7a at test size, run through the whole pipeline (report.html included)."""
    from torsal.pipeline.report_3d import FAMILY_COLOURS, SUN_COLOUR

    out = small_7a.out
    browser.errors.clear()
    browser.requests.clear()
    ready = ("(() => { const g = document.getElementById('torsal-3d');"
             "return g && g._fullLayout && g.querySelector('canvas') && g._fullData.length > 0; })()")
    browser.open((out / "report.html").as_uri(), ready=ready)
    browser.settle(1.0)  # WebGL draws after the plot's first layout
    assert browser.errors == []
    # offline: every request is the page itself, its images or inlined data
    remote = [u for u in browser.requests if not u.startswith(("file:", "data:", "blob:"))]
    assert remote == []
    traces = browser.evaluate("document.getElementById('torsal-3d')._fullData.map(t => t.name)")
    assert any("surface A" in t for t in traces)
    assert any("family 0" in t for t in traces) and any("family 1" in t for t in traces)
    assert any(t.startswith("sun: heaviest") for t in traces)
    canvas = browser.evaluate("(() => { const c = document.querySelector('#torsal-3d canvas');"
                              "return [c.width, c.height, !!(c.getContext('webgl') ||"
                              " c.getContext('webgl2') || c.getContext('experimental-webgl'))]; })()")
    assert canvas[0] > 300 and canvas[1] > 300 and canvas[2], canvas
    png = browser.screenshot("#torsal-3d")
    (out / "report_3d.png").write_bytes(png)
    # the fins and the sun rays are on screen in their colours (shaded, so told by hue)
    for colour in (*FAMILY_COLOURS, SUN_COLOUR):
        assert _hue_share(png, colour) > 0.002, (colour, _hue_share(png, colour), out / "report_3d.png")
    if os.environ.get("TORSAL_KEEP_SCREENSHOT"):
        shutil.copy(out / "report_3d.png", os.environ["TORSAL_KEEP_SCREENSHOT"])
