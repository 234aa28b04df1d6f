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


def browser_check(path: Path, width: int = 1280, height: int = 900) -> dict:
    """Load the page in headless Chromium at ``width`` x ``height`` px, after its load event: the
    number of images, those not decoded (``broken``: their alt texts), the document's scroll width
    against the window's, the elements reaching past the window's right edge and the smallest table
    font [px]. A copy of the page with a probe script is loaded (the page itself has none)."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory() as d:
        probe = Path(d) / path.name
        probe.write_text(text.replace("</body>", _PROBE + "\n</body>"), encoding="utf-8")
        r = _chromium([f"--window-size={width},{height}", "--virtual-time-budget=10000", "--dump-dom",
                       probe.as_uri()])
    m = re.search(r'<pre id="gearopt-probe">(.*?)</pre>', r.stdout, re.S)
    assert m, f"the probe did not run (chromium exit {r.returncode}): {r.stderr[-800:]}"
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))


def screenshot(path: Path, png: Path, width: int = 1280, height: int = 4000) -> Path:
    """A screenshot of the page's top ``height`` px at ``width`` px into ``png``."""
    r = _chromium([f"--window-size={width},{height}", f"--screenshot={png}", "--virtual-time-budget=10000",
                   Path(path).resolve().as_uri()])
    assert Path(png).is_file(), f"no screenshot (chromium exit {r.returncode}): {r.stderr[-800:]}"
    return Path(png)
