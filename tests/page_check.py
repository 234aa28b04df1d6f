"""Checks of a self-contained HTML page (report.html, the compare page) as a person opens it: parsed
with the standard library's HTMLParser (every image inline, every link to an existing file beside
the page, nothing fetched from elsewhere) and loaded in headless Chromium (every image decoded,
nothing wider than the window). Independent of gearopt's code."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlparse

#: The browser binary names tried, in order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def browser() -> str | None:
    """Path of a Chromium binary, or None."""
    for b in BROWSERS:
        p = shutil.which(b)
        if p:
            return p
    return None


class _Page(HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.images: list[str] = []
        self.links: list[str] = []
        self.resources: list[tuple[str, str]] = []  # (tag, url) of anything the browser would fetch
        self.tables: list[list[list[str]]] = []
        self.stack: list[str] = []
        self._cell: list[str] | None = None
        self.text: list[str] = []
        self.figcaptions: list[str] = []
        self._cap: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag not in ("br", "img", "meta", "link", "input", "hr"):
            self.stack.append(tag)
        if tag == "img":
            self.images.append(a.get("src") or "")
        elif tag == "a" and a.get("href"):
            self.links.append(a["href"])
        elif tag in ("script", "iframe", "embed", "object", "source", "video", "audio") and (a.get("src") or a.get("data")):
            self.resources.append((tag, a.get("src") or a.get("data")))
        elif tag == "link" and a.get("href"):
            self.resources.append((tag, a["href"]))
        elif tag == "table":
            self.tables.append([])
        elif tag == "tr" and self.tables:
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "figcaption":
            self._cap = []

    def handle_endtag(self, tag):
        if self.stack and self.stack[-1] == tag:
            self.stack.pop()
        if tag in ("td", "th") and self._cell is not None and self.tables and self.tables[-1]:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None
        if tag == "figcaption" and self._cap is not None:
            self.figcaptions.append("".join(self._cap).strip())
            self._cap = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._cap is not None:
            self._cap.append(data)


def parse(path: Path) -> _Page:
    p = _Page()
    p.feed(Path(path).read_text(encoding="utf-8"))
    p.close()
    return p


def static_problems(path: Path) -> list[str]:
    """What is wrong with the page as a file: images not inline (``data:``), links that do not
    point to an existing file beside the page, anything fetched from elsewhere (scripts, style
    sheets, ``url(http...)`` in the CSS), unclosed elements."""
    path = Path(path)
    page = parse(path)
    text = path.read_text(encoding="utf-8")
    out = []
    for src in page.images:
        if not src.startswith(("data:image/png;base64,", "data:image/svg+xml;base64,", "data:image/jpeg;base64,")):
            out.append(f"image not inline: {src[:60]!r}")
    for href in page.links:
        u = urlparse(href)
        if u.scheme or u.netloc:
            out.append(f"link leaves the directory: {href!r}")
            continue
        if not u.path:
            continue  # a fragment (#warnings)
        target = (path.parent / unquote(u.path)).resolve()
        if not target.is_file():
            out.append(f"link to a missing file: {href!r}")
        elif path.parent.resolve() not in target.parents:
            out.append(f"link outside the page's directory: {href!r}")
    for tag, url in page.resources:
        out.append(f"<{tag}> fetches {url!r}")
    if re.search(r"url\(\s*['\"]?(?:https?:|//)", text) or re.search(r"@import", text):
        out.append("the style sheet fetches something")
    if page.stack:
        out.append(f"unclosed elements: {page.stack}")
    return out


_PROBE = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var wide = [];
  document.querySelectorAll('body *').forEach(function (e) {
    var r = e.getBoundingClientRect();
    if (r.right > window.innerWidth + 0.5) wide.push(e.tagName + (e.className ? '.' + e.className : ''));
  });
  var out = {n_images: imgs.length,
             broken: imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
                         .map(function (i) { return i.alt; }),
             scroll_width: document.documentElement.scrollWidth, inner_width: window.innerWidth,
             wider: wide.slice(0, 10),
             smallest_table_font_px: Math.min.apply(null, Array.prototype.slice.call(
                 document.querySelectorAll('td, th')).map(function (c) {
                   return parseFloat(getComputedStyle(c).fontSize); }).concat([99]))};
  var pre = document.createElement('pre');
  pre.id = 'gearopt-probe';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


def _chromium(args: list[str], timeout: float = 120) -> subprocess.CompletedProcess:
    exe = browser()
    assert exe is not None
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
           "--disable-extensions", "--mute-audio", *args]
    env = {**os.environ, "HOME": tempfile.gettempdir()}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


class Browser:
    """One headless Chromium for every page of a test process, driven over the DevTools protocol on
    a pipe (``--remote-debugging-pipe``: the commands on its fd 3, the answers and events on its fd 4,
    each a JSON message ended by a NUL byte). Each page opens in a new tab of ``width`` x ``height``
    px, closed after it. A Chromium start is 1-3 s of wall and about 1 s of CPU; the pages of
    test_report_page.py and test_compare.py share one (:func:`shared_browser`)."""

    def __init__(self, timeout: float = 120):
        import fcntl

        exe = browser()
        assert exe is not None
        self.timeout = timeout
        self._dir = tempfile.TemporaryDirectory()
        cmd_r, cmd_w = os.pipe()  # we write the commands, Chromium reads them on its fd 3
        out_r, out_w = os.pipe()  # Chromium writes on its fd 4, we read
        # above 4, so that the child's dup2 onto 3 and 4 below cannot overwrite one with the other
        hi_r, hi_w = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (cmd_r, out_w))

        def onto_3_and_4():
            os.dup2(hi_r, 3)
            os.dup2(hi_w, 4)

        cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
               "--disable-extensions", "--mute-audio", "--remote-debugging-pipe", f"--user-data-dir={self._dir.name}",
               "about:blank"]
        env = {**os.environ, "HOME": tempfile.gettempdir()}
        self._log = Path(self._dir.name) / "stderr.txt"  # a file: a pipe nobody reads would fill and block it
        with open(self._log, "wb") as log:
            self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                                         env=env, pass_fds=(3, 4), preexec_fn=onto_3_and_4)
        for fd in (cmd_r, out_w, hi_r, hi_w):
            os.close(fd)
        self._w = os.fdopen(cmd_w, "wb", buffering=0)
        self._r = out_r
        self._buf = b""
        self._id = 0
        self._events: list[dict] = []

    def _message(self, deadline: float) -> dict:
        import select
        import time

        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._r], [], [], left)[0]:
                raise AssertionError(f"Chromium did not answer over its DevTools pipe in time: {self.stderr()}")
            chunk = os.read(self._r, 1 << 20)
            if not chunk:
                raise AssertionError(f"Chromium closed its DevTools pipe (exit {self.proc.poll()}): {self.stderr()}")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def stderr(self) -> str:
        """The end of what Chromium wrote on its standard error."""
        return self._log.read_text(errors="replace")[-800:] if self._log.exists() else ""

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Run one DevTools command and return its result (events that arrive meanwhile are kept)."""
        import time

        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        self._w.write(json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            m = self._message(deadline)
            if m.get("id") == self._id:
                assert "error" not in m, f"DevTools {method}: {m['error']}"
                return m.get("result", {})
            self._events.append(m)

    def wait_event(self, method: str, session: str) -> dict:
        """The next event ``method`` of the tab ``session``."""
        import time

        deadline = time.monotonic() + self.timeout
        while True:
            for i, m in enumerate(self._events):
                if m.get("method") == method and m.get("sessionId") == session:
                    return self._events.pop(i)
            self._events.append(self._message(deadline))

    def evaluate_after_load(self, url: str, expression: str, width: int, height: int) -> object:
        """Open ``url`` in a new ``width`` x ``height`` px tab, wait for its load event, and return the
        value of ``expression`` (a promise is awaited) in the page."""
        target = self.send("Target.createTarget", {"url": "about:blank", "width": width, "height": height, "newWindow": True})["targetId"]
        session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        try:
            self.send("Page.enable", {}, session)
            self.send("Page.navigate", {"url": url}, session)
            self.wait_event("Page.loadEventFired", session)
            r = self.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True, "returnByValue": True},
                          session)
            assert "exceptionDetails" not in r, r["exceptionDetails"]
            return r["result"].get("value")
        finally:
            self.send("Target.closeTarget", {"targetId": target})
            self._events = [m for m in self._events if m.get("sessionId") != session]

    def close(self) -> None:
        """End Chromium (its pipe closed, it exits) and remove its profile directory; idempotent."""
        if self._w.closed:
            return
        try:
            self._w.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        finally:
            os.close(self._r)
            self._dir.cleanup()


_SHARED: list[Browser] = []


def shared_browser() -> Browser:
    """The test process's one :class:`Browser`, started at the first page and closed at exit."""
    import atexit

    if not _SHARED or _SHARED[0].proc.poll() is not None:
        _SHARED[:] = [Browser()]
        atexit.register(_SHARED[0].close)
    return _SHARED[0]


#: The probe's result, read once the load event has run it (it writes a <pre> at the load event).
_READ_PROBE = """new Promise(function (done) {
  (function poll() {
    var e = document.getElementById('gearopt-probe');
    if (e) { done(e.textContent); } else { setTimeout(poll, 10); }
  })();
})"""


def browser_check(path: Path, width: int = 1280, height: int = 900) -> dict:
    """Load the page in headless Chromium at ``width`` x ``height`` px, after its load event: the
    number of images, those not decoded (``broken``: their alt texts), the document's scroll width
    against the window's, the elements reaching past the window's right edge and the smallest table
    font [px]. A copy of the page with a probe script is loaded (the page itself has none), in a new
    tab of the test process's one browser (:func:`shared_browser`)."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory() as d:
        probe = Path(d) / path.name
        probe.write_text(text.replace("</body>", _PROBE + "\n</body>"), encoding="utf-8")
        value = shared_browser().evaluate_after_load(probe.as_uri(), _READ_PROBE, width, height)
    assert isinstance(value, str), f"the probe did not run: {value!r}"
    return json.loads(value)


def screenshot(path: Path, png: Path, width: int = 1280, height: int = 4000) -> Path:
    """A screenshot of the page's top ``height`` px at ``width`` px into ``png``."""
    r = _chromium([f"--window-size={width},{height}", f"--screenshot={png}", "--virtual-time-budget=10000",
                   Path(path).resolve().as_uri()])
    assert Path(png).is_file(), f"no screenshot (chromium exit {r.returncode}): {r.stderr[-800:]}"
    return Path(png)
