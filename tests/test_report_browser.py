"""report.html in a real browser (issue 52, deliverable 9).

A tiny scene is segmented (``graphseg run``, about a second) and its
``report.html`` is opened from a ``file://`` URL in headless Chromium, driven
over the DevTools protocol through ``--remote-debugging-pipe`` (NUL-separated
JSON on file descriptors 3 and 4: no websocket library, no port). The page
must load offline (every request is ``file:`` / ``data:``; a dead proxy makes
any other fail), with no uncaught exception, no ``console.error`` and no
browser log entry of level error; its 3D view (a 2D canvas, no WebGL) must
have drawn into the canvas (pixels read back with ``getImageData``: the
background and points of several colours) and redraw when dragged with the
mouse; the overlays (one decoded image per view) and the metrics and audit
tables must be there.

:func:`check_report` is the checker; the other tests run it on broken copies
(a script that throws, a console error and a remote image, a view that does
not turn) and assert that it reports each, so a broken page cannot pass.

No browser found (``chromium``, ``chromium-browser``, ``google-chrome``, or the
path in ``GRAPHSEG_BROWSER``): the tests skip with that reason, unless
``GRAPHSEG_REQUIRE_BROWSER=1`` (CI) turns the skip into a failure.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import shutil
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from graphseg.cli import main
from graphseg.io import write_scene_folder
from graphseg.testing.scenes import TWO_BOXES, box_scene

VIEWS = 3
OBJECTS = ("box1", "box2")  # the names of TWO_BOXES, rows of the metrics table
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_browser() -> str | None:
    """The Chromium binary: ``$GRAPHSEG_BROWSER``, else the first of :data:`BROWSERS` on ``PATH``."""
    env = os.environ.get("GRAPHSEG_BROWSER")
    if env:
        return env if os.access(env, os.X_OK) else None
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


class BrowserError(RuntimeError):
    pass


class Browser:
    """Headless Chromium driven over the DevTools protocol on a pipe (fd 3: commands in, fd 4: replies out)."""

    def __init__(self, binary: str, *, timeout: float = 20.0) -> None:
        self.timeout = timeout
        self.profile = tempfile.mkdtemp(prefix="graphseg-chromium-")
        self._buf = b""
        self._id = 0
        self.events: list[dict[str, Any]] = []
        self._log = tempfile.TemporaryFile()
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        args = [
            binary,
            "--headless",
            "--no-sandbox",  # root in CI containers
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--disable-quic",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-extensions",
            "--disable-default-apps",
            "--mute-audio",
            "--proxy-server=127.0.0.1:9",  # offline: anything that is not file:/data: fails (and is recorded below)
            "--proxy-bypass-list=<-loopback>",
            f"--user-data-dir={self.profile}",
            "--remote-debugging-pipe",
            "about:blank",
        ]
        # bash puts the two pipe ends on the descriptors the protocol expects, then execs the browser
        launcher = f'exec "$@" 3<&{to_child_r} 4>&{from_child_w} {to_child_r}<&- {from_child_w}>&-'
        self.proc: subprocess.Popen[bytes] | None = None
        try:
            self.proc = subprocess.Popen(
                ["bash", "-c", launcher, "browser", *args],
                pass_fds=(to_child_r, from_child_w),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=self._log,  # a file, not a pipe: a chatty browser cannot block on a full pipe
                start_new_session=True,  # its own process group: closed as one in close()
            )
        except BaseException:
            self.close()
            raise
        finally:
            os.close(to_child_r)
            os.close(from_child_w)
        try:
            self.send("Target.setDiscoverTargets", {"discover": False})  # a first round trip: the browser is up
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ protocol
    def _read_message(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrowserError(f"no answer from the browser in {self.timeout:g} s")
            ready, _, _ = select.select([self._from_child], [], [], left)
            if not ready:
                continue
            chunk = os.read(self._from_child, 1 << 20)
            if not chunk:
                status = self.proc.wait(timeout=5) if self.proc is not None else None
                raise BrowserError(f"the browser exited (status {status}): {self._stderr_tail()}")
            self._buf += chunk
        raw, _, self._buf = self._buf.partition(b"\0")
        return json.loads(raw)

    def send(self, method: str, params: dict[str, Any] | None = None, session: str | None = None) -> dict[str, Any]:
        """Send one command and return its ``result``; events read meanwhile go to :attr:`events`."""
        self._id += 1
        msg: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        data = json.dumps(msg).encode() + b"\0"
        while data:
            data = data[os.write(self._to_child, data):]
        deadline = time.monotonic() + self.timeout
        while True:
            reply = self._read_message(deadline)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})
            if "method" in reply:
                self.events.append(reply)

    def wait_for(self, method: str, session: str) -> dict[str, Any]:
        """Read events until ``method`` arrives for ``session``."""
        deadline = time.monotonic() + self.timeout
        for ev in self.events:
            if ev["method"] == method and ev.get("sessionId") == session:
                return ev
        while True:
            ev = self._read_message(deadline)
            if "method" in ev:
                self.events.append(ev)
                if ev["method"] == method and ev.get("sessionId") == session:
                    return ev

    def _stderr_tail(self) -> str:
        self._log.seek(0)
        return " | ".join(self._log.read().decode(errors="replace").strip().splitlines()[-3:])

    def close(self) -> None:
        """Close the browser (Browser.close, then SIGKILL to its process group) and remove its profile."""
        try:
            if self.proc is not None and self.proc.poll() is None:
                try:
                    self._id += 1
                    os.write(self._to_child, json.dumps({"id": self._id, "method": "Browser.close"}).encode() + b"\0")
                    self.proc.wait(timeout=5)
                except (OSError, subprocess.TimeoutExpired):
                    pass
            # the renderer / zygote children share the group even when the browser process is gone
            if self.proc is not None:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.proc.wait(timeout=5)
        finally:
            for fd in (self._to_child, self._from_child):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self._log.close()
            shutil.rmtree(self.profile, ignore_errors=True)


# ----------------------------------------------------------------------------- the checker
# Run in the page after its load event: what the report drew and wrote.
SIGNATURE = r"""
(() => {
  const cv = document.getElementById('cloud');
  const px = cv.getContext('2d').getImageData(0, 0, cv.width, cv.height).data;
  let h = 0;
  for (let i = 0; i < px.length; i += 4) h = (h * 31 + px[i] + 7 * px[i + 1] + 13 * px[i + 2]) | 0;
  return h;
})()
"""

PROBE = r"""
(() => {
  const out = {};
  const cv = document.getElementById('cloud');
  out.canvas = null;
  if (cv) {
    const px = cv.getContext('2d').getImageData(0, 0, cv.width, cv.height).data;
    const bg = [px[0], px[1], px[2]];
    const colours = new Set();
    let other = 0, transparent = 0;
    for (let i = 0; i < px.length; i += 4) {
      if (px[i + 3] === 0) transparent++;
      if (px[i] !== bg[0] || px[i + 1] !== bg[1] || px[i + 2] !== bg[2]) other++;
      if (colours.size < 1000) colours.add((px[i] << 16) | (px[i + 1] << 8) | px[i + 2]);
    }
    cv.scrollIntoView({block: 'center'});
    const r = cv.getBoundingClientRect();
    out.canvas = {width: cv.width, height: cv.height, background: bg, other: other,
                  transparent: transparent, colours: colours.size,
                  centre: [r.left + r.width / 2, r.top + r.height / 2]};
  }
  out.figures = [...document.querySelectorAll('figure')].map(f => {
    const img = f.querySelector('img');
    return {caption: (f.querySelector('figcaption') || {}).textContent || '',
            loaded: !!img && img.complete && img.naturalWidth > 0, width: img ? img.naturalWidth : 0};
  });
  out.headings = [...document.querySelectorAll('h2')].map(h => h.textContent);
  out.tables = [...document.querySelectorAll('table')].map(t =>
    [...t.querySelectorAll('tr')].map(r => [...r.children].map(c => c.textContent)));
  out.title = document.title;
  return out;
})()
"""

OFFLINE_SCHEMES = ("file:", "data:", "about:", "blob:")


@dataclass
class PageCheck:
    """What :func:`check_report` found: ``problems`` is empty for a good page."""

    problems: list[str] = field(default_factory=list)
    page: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0


def _event_problem(ev: dict[str, Any]) -> str | None:
    m, p = ev["method"], ev.get("params", {})
    if m == "Runtime.exceptionThrown":
        d = p.get("exceptionDetails", {})
        text = (d.get("exception") or {}).get("description") or d.get("text", "")
        return f"uncaught exception: {text.splitlines()[0] if text else '?'} (line {d.get('lineNumber')})"
    if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
        args = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
        return f"console.{p['type']}: {args}"
    if m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
        e = p["entry"]
        return f"log error ({e.get('source')}): {e.get('text')} {e.get('url', '')}".strip()
    if m == "Network.requestWillBeSent":
        url = p.get("request", {}).get("url", "")
        if not url.startswith(OFFLINE_SCHEMES):
            return f"network request: {url[:120]}"
    if m == "Network.loadingFailed" and not p.get("canceled"):
        return f"request failed: {p.get('errorText')}"
    if m == "Inspector.targetCrashed":
        return "the page crashed"
    return None


def _drag_changes_the_view(browser: Browser, session: str, centre: list[float]) -> bool:
    """Drag across the canvas with the mouse (as a user rotates the cloud) and say whether its pixels changed."""
    before = browser.send("Runtime.evaluate", {"expression": SIGNATURE, "returnByValue": True}, session=session)["result"].get("value")
    x, y = centre
    for kind, dx in (("mousePressed", 0), ("mouseMoved", 40), ("mouseMoved", 80), ("mouseReleased", 80)):
        browser.send("Input.dispatchMouseEvent", {"type": kind, "x": x + dx, "y": y, "button": "left", "buttons": 0 if kind == "mouseReleased" else 1, "clickCount": 1}, session=session)
    after = browser.send("Runtime.evaluate", {"expression": SIGNATURE, "returnByValue": True}, session=session)["result"].get("value")
    return before is not None and after is not None and before != after


def check_report(browser: Browser, path: Path, *, views: int, objects: tuple[str, ...]) -> PageCheck:
    """Open ``path`` in a new tab of ``browser`` and list what is wrong with it (see the module docstring).

    ``views``: the number of overlays expected; ``objects``: the rows of the metrics table before ``mean``.
    """
    t0 = time.monotonic()
    target = browser.send("Target.createTarget", {"url": "about:blank"})["targetId"]
    session = browser.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
    out = PageCheck()
    try:
        for domain in ("Runtime", "Log", "Page", "Network", "Inspector"):
            browser.send(f"{domain}.enable", session=session)
        start = len(browser.events)
        browser.send("Page.navigate", {"url": path.resolve().as_uri()}, session=session)
        browser.wait_for("Page.loadEventFired", session)
        # two animation frames: anything the page does right after load has happened
        browser.send(
            "Runtime.evaluate",
            {"expression": "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(1))))", "awaitPromise": True},
            session=session,
        )
        res = browser.send("Runtime.evaluate", {"expression": PROBE, "returnByValue": True}, session=session)
        if "exceptionDetails" in res:
            out.problems.append(f"probe failed: {res['exceptionDetails'].get('text')}")
            page: dict[str, Any] = {}
        else:
            page = res["result"]["value"]
        out.page = page
        c = page.get("canvas")
        if c and c["other"] and not _drag_changes_the_view(browser, session, c["centre"]):
            out.problems.append("dragging the 3D view did not redraw it")
        for ev in browser.events[start:]:
            if ev.get("sessionId") == session:
                msg = _event_problem(ev)
                if msg:
                    out.problems.append(msg)
    finally:
        browser.send("Target.closeTarget", {"targetId": target})
    if page:
        c = page.get("canvas")
        if not c:
            out.problems.append("no canvas #cloud")
        else:
            # the viewer fills the canvas with its background (#111) and draws each point over it
            if c["background"] != [17, 17, 17] or c["transparent"]:
                out.problems.append(f"the 3D view did not paint its background (corner {c['background']}, {c['transparent']} transparent pixels)")
            if c["other"] < 50 or c["colours"] < 3:
                out.problems.append(f"the 3D view drew no points ({c['other']} pixels off the background, {c['colours']} colours)")
        figs = page["figures"]
        if len(figs) != views or not all(f["loaded"] for f in figs):
            out.problems.append(f"overlays: {sum(f['loaded'] for f in figs)} of {len(figs)} images decoded, {views} views expected")
        for h in ("Metrics", "3D objects", "Views", "Edge audit"):
            if h not in page["headings"]:
                out.problems.append(f"section {h!r} missing (headings: {page['headings']})")
        tables = page["tables"]
        metrics = next((t for t in tables if t and t[0][:2] == ["object", "iou"]), None)
        if metrics is None:
            out.problems.append("no metrics table")
        else:
            names = [r[0] for r in metrics[1:]]
            if names != [*objects, "mean"] or not all(len(r) == len(metrics[0]) for r in metrics):
                out.problems.append(f"metrics table rows: {names}")
        if len(tables) < 2:
            out.problems.append(f"{len(tables)} tables, expected the metrics and the audit table")
    out.seconds = time.monotonic() - t0
    return out


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def browser():
    binary = find_browser()
    if binary is None:
        env = os.environ.get("GRAPHSEG_BROWSER")
        reason = f"GRAPHSEG_BROWSER={env} is not an executable" if env else f"no Chromium on PATH ({', '.join(BROWSERS)}; apt-get install chromium)"
        if os.environ.get("GRAPHSEG_REQUIRE_BROWSER") == "1":
            pytest.fail(reason + " (GRAPHSEG_REQUIRE_BROWSER=1)")
        pytest.skip(reason)
    b = Browser(binary)
    try:
        yield b
    finally:
        b.close()


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    d = tmp_path_factory.mktemp("report_browser")
    write_scene_folder(box_scene(TWO_BOXES, views=VIEWS, shape=(60, 80)), d / "scene")
    assert main(["run", str(d / "scene"), "-o", str(d / "out"), "--quiet"]) == 0
    return d / "out" / "report.html"


# ----------------------------------------------------------------------------- tests
def test_report_loads_offline_draws_and_shows_its_tables(browser, report):
    check = check_report(browser, report, views=VIEWS, objects=OBJECTS)
    assert check.problems == [], check.problems
    c = check.page["canvas"]
    assert (c["width"], c["height"]) == (900, 600)
    assert [f["caption"] for f in check.page["figures"]] == ["000", "001", "002"]
    assert check.page["title"].startswith("graphseg: ")


def test_checker_reports_a_page_whose_script_throws(browser, report, tmp_path):
    page = report.read_text(encoding="utf-8")
    marker = "<script>\n(function(){"
    assert page.count(marker) == 1
    broken = tmp_path / "report.html"
    broken.write_text(page.replace(marker, '<script>\nthrow new Error("boom");\n(function(){'), encoding="utf-8")
    check = check_report(browser, broken, views=VIEWS, objects=OBJECTS)
    assert any(p.startswith("uncaught exception: Error: boom") for p in check.problems), check.problems
    assert any("drew no points" in p or "did not paint" in p for p in check.problems), check.problems  # and the view stayed blank


def test_checker_reports_console_errors_and_network_requests(browser, report, tmp_path):
    page = report.read_text(encoding="utf-8")
    broken = tmp_path / "report.html"
    extra = '<script>console.error("bad thing");</script><img src="http://example.invalid/x.png">'
    broken.write_text(page.replace("</body>", extra + "</body>"), encoding="utf-8")
    check = check_report(browser, broken, views=VIEWS, objects=OBJECTS)
    assert "console.error: bad thing" in check.problems, check.problems
    assert any(p.startswith("network request: http://example.invalid/") for p in check.problems), check.problems


def test_checker_reports_a_view_that_does_not_turn(browser, report, tmp_path):
    page = report.read_text(encoding="utf-8")
    broken = tmp_path / "report.html"
    # a capturing listener swallows the mouse button before the viewer's own: dragging no longer rotates the cloud
    stop = "<script>window.addEventListener('mousedown', e => e.stopPropagation(), true);</script>"
    broken.write_text(page.replace("</head>", stop + "</head>"), encoding="utf-8")
    check = check_report(browser, broken, views=VIEWS, objects=OBJECTS)
    assert check.problems == ["dragging the 3D view did not redraw it"], check.problems
