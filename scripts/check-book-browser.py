#!/usr/bin/env python3
"""Check a built mdBook in a real browser: open every page of BOOK_DIR in
headless Chromium and fail on what a reader would see go wrong.

    scripts/check-book-browser.py BOOK_DIR [--screenshots DIR]

Each page is loaded as a file:// URL (as a reader opens book/book/ from
disk) in a 1280x900 window, and once its load event has fired, its images
have decoded and its fonts are ready, the page is checked for:

- maths errors: MathML <merror> elements and KaTeX's .katex-error nodes
  (what KaTeX leaves where it could not parse an equation);
- raw TeX: visible text outside <pre>, <code> and <math> holding `$$`, a
  `$...$` pair, `^{`, `_{` or a TeX control word (\\frac, \\mathbf, \\sum,
  \\left, \\begin...). A pair follows Pandoc's rule for inline maths: the
  opening `$` has a non-space after it, the closing one a non-space before
  it and no digit after it, so prose like "from $5 to $10" is no pair;
  and one that starts with a digit counts only with \\, ^, _, {, } or =
  in it, so "$10, or US$ 12" is none either (but "$2^k$" is);
  text is joined per block (paragraph, list item, cell...), and code inside
  a block breaks it, so a `$` in prose never pairs with one in code;
- images that did not load: an <img> the browser could not decode (decode()
  rejects; this also covers an SVG, whose naturalWidth can be 0 when it has
  no intrinsic size) or that is complete with naturalWidth 0; <object>,
  <embed> and <iframe> elements outside <noscript> with nothing to show;
- a page wider than the viewport: mdBook clips its pages at the window's
  right edge (body {overflow-x: hidden}), so what reaches past it is cut
  off rather than scrollable and document.documentElement.scrollWidth does
  not grow. So besides that (scrollWidth > clientWidth + 1 px, clientWidth
  being the viewport less its vertical scrollbar), every element of the
  chapter (<main>) is measured, and one reaching past either edge of the
  viewport by more than 1 px is reported, with its equation's text for
  maths, unless it lies inside a horizontal scroller that fits (a code
  block, mdBook's .table-wrapper): the reader can scroll that;
- console errors: console.error() calls, uncaught exceptions (also in
  promises) and browser log entries of level "error", which is where a
  resource (stylesheet, script, font, image) that failed to load shows up.
  None is allowed: mdBook's own scripts log no error under file:// (the
  search index is a script loaded only when search is opened, and the Rust
  playground is only contacted for runnable Rust blocks, which the book
  has none of; a runnable one would fetch play.rust-lang.org, and its
  failure offline is rightly reported).

Which pages: every .html file under BOOK_DIR (subfolders too, such as
reference/; index.html, mdBook's copy of the first chapter, too), except
- toc.html: the sidebar as a frame, shown only when JavaScript is off; its
  links are the sidebar's, which every page shows anyway;
- 404.html: it has <base href="/"> (output.html.site-url), for a web
  server to serve it from any folder, so from file:// its stylesheets and
  scripts cannot load, by design;
and including print.html, the whole book on one page (what a reader prints
or saves as PDF). It is the largest page, every chapter and figure, but
costs only about as much as two chapters (its figures are in the cache by
then), and it checks what no chapter does: mdBook rewrites the relative
links and image paths of the pages in subfolders (reference/) to work from
the root there, and every chapter's maths and figures meet on one page.

Screenshots (PNG) of a few pages are written to the --screenshots folder
(book-screenshots/ beside BOOK_DIR, so book/book-screenshots/, by default)
for a reviewer to look at: the introduction, a maths-heavy chapter
(derivatives.html), a chapter of measured figures (anti-aliasing.html) and
global-illumination.html. Each is the whole page, top to bottom, at the
window's width, not its first viewport: what a reviewer looks for (an
equation that renders badly, a figure squashed or missing) is anywhere on
the page, and the first 900 px of a chapter are mostly prose. (The sidebar
is fixed to the window, so it shows at the top only.) A page taller
than MAX_SHOT_HEIGHT px is captured down to there, and the output says so.
The four take about a third of the run (encoding PNGs some 16,000 px tall).

Python's standard library only: Chromium is driven over the DevTools
protocol on a pipe (--remote-debugging-pipe: JSON messages ended by a NUL
byte, the browser reading fd 3 and writing fd 4). The `chromium` command is
Debian's chromium package (scripts/install-browser, run by make deps);
$CHROMIUM names another binary. Without one this exits 1 saying so: the
check is never skipped. Each page has PAGE_TIMEOUT seconds, and the browser
is killed on exit, so a hung browser cannot hang `make test`.

Exit status 1, with each problem listed as "page: problem: detail", when
any is found; 0 with a one-line summary otherwise."""

import argparse
import base64
import fcntl
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WIDTH, HEIGHT = 1280, 900
PAGE_TIMEOUT = 30.0  # seconds for one page: load, checks, screenshot
START_TIMEOUT = 30.0  # seconds for the browser to answer its first message
MAX_SHOT_HEIGHT = 32000  # pixels; taller pages are captured down to here
SKIP = {"toc.html", "404.html"}
SCREENSHOTS = ["introduction.html", "derivatives.html", "anti-aliasing.html",
               "global-illumination.html"]

# Runs in the page once it has loaded; resolves to what it found.
CHECK_JS = r"""
(async () => {
  const problems = [];
  const describe = (el) => {
    let s = el.tagName.toLowerCase();
    if (el.id) s += '#' + el.id;
    if (el.getAttribute('display')) s += ` display="${el.getAttribute('display')}"`;
    const cls = (el.getAttribute('class') || '').trim();
    if (cls) s += '.' + cls.split(/\s+/).join('.');
    return s;
  };
  const headings = Array.from(document.querySelectorAll(
    'main h1, main h2, main h3, main h4, main h5, main h6'));
  const near = (el) => {
    // The last heading before an element, to say where on the page it is.
    let heading = null;
    for (const h of headings) {
      if (h === el || !(h.compareDocumentPosition(el) & Node.DOCUMENT_POSITION_FOLLOWING)) break;
      heading = h;
    }
    return heading ? ` (under "${heading.textContent.trim().slice(0, 60)}")` : '';
  };
  const clip = (s, n = 100) => {
    s = s.replace(/\s+/g, ' ').trim();
    return s.length > n ? s.slice(0, n) + '…' : s;
  };

  // Images: every <img> to be fetched now (none waits for scrolling), then
  // decoded; decode() rejects for a broken image.
  const imgs = Array.from(document.images);
  for (const img of imgs) img.loading = 'eager';
  await Promise.all(imgs.map(async (img) => {
    let why = null;
    try { await img.decode(); } catch (e) { why = 'could not be decoded or loaded'; }
    if (!why && img.complete && img.naturalWidth === 0 && !/\.svg([?#]|$)/i.test(img.currentSrc || img.src))
      why = 'loaded with no pixels (naturalWidth 0)';
    if (why) problems.push(['image did not load',
      `${img.getAttribute('src')}: ${why}${near(img)}`]);
  }));
  for (const el of document.querySelectorAll('object, embed, iframe')) {
    if (el.closest('noscript')) continue;
    const r = el.getBoundingClientRect();
    if (r.width === 0 || r.height === 0)
      problems.push(['embedded content did not show',
        `<${el.tagName.toLowerCase()}> ${el.getAttribute('data') || el.getAttribute('src')}${near(el)}`]);
  }
  await document.fonts.ready;
  await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));

  // Maths errors.
  for (const el of document.querySelectorAll('merror, .katex-error')) {
    const tex = el.getAttribute('title') || el.textContent;
    problems.push(['maths error', `<${describe(el)}>: ${clip(tex)}${near(el)}`]);
  }

  // Raw TeX in visible text outside code and rendered maths, joined per block.
  const BLOCK = 'p, li, dt, dd, td, th, h1, h2, h3, h4, h5, h6, figcaption, caption, ' +
                'blockquote, summary, div, main, body';
  const EXCLUDED = 'pre, code, kbd, samp, script, style, noscript, template, math, svg, textarea, .katex-error';
  const blocks = new Map();
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let t = walker.nextNode(); t; t = walker.nextNode()) {
    const parent = t.parentElement;
    if (!parent) continue;
    const block = parent.closest(BLOCK);
    if (!blocks.has(block)) blocks.set(block, []);
    if (parent.closest(EXCLUDED)) { blocks.get(block).push('\n'); continue; }
    if (!parent.checkVisibility()) continue;
    blocks.get(block).push(t.data);
  }
  const TEX = [
    [/\$\$/g, '$$'],
    [/(?<![\\$])\$(?=[^\s$])[^$\n]*?[^\s$\\]\$(?![\d$])|(?<![\\$])\$[^\s$]\$(?![\d$])/g, '$…$ pair',
     // "$10, or US$": a pair that starts with a digit is TeX only with TeX in it.
     (m) => !/^\$\d/.test(m) || /[\\^_{}=]/.test(m)],
    [/\\(?:[A-Za-z]{2,}|[{}[\]()|,;!])/g, 'TeX control word'],
    [/[\^_]\{/g, 'superscript or subscript braces'],
  ];
  for (const [block, parts] of blocks) {
    const text = parts.join('');
    for (const [re, what, keep] of TEX) {
      // The first of each kind in a block, and how many more.
      const found = Array.from(text.matchAll(re)).filter((m) => !keep || keep(m[0]));
      if (!found.length) continue;
      const m = found[0];
      const from = Math.max(0, m.index - 40), to = Math.min(text.length, m.index + m[0].length + 40);
      const more = found.length > 1 ? ` (and ${found.length - 1} more)` : '';
      problems.push(['raw TeX', `${what} ${JSON.stringify(m[0])}${more} in "${clip(text.slice(from, to), 120)}"${near(block)}`]);
    }
  }

  // Wider than the viewport. mdBook clips the page at the window's right
  // edge (body {overflow-x: hidden}, #mdbook-body-container {overflow-x:
  // clip}), so content reaching past it is cut off, not scrollable, and the
  // document's own scrollWidth does not grow: each element of the chapter is
  // measured instead. One inside a horizontal scroller that fits (a code
  // block, mdBook's .table-wrapper) is fine: the reader scrolls it.
  const root = document.documentElement;
  const vw = root.clientWidth;  // the viewport less its vertical scrollbar
  if (root.scrollWidth > vw + 1)
    problems.push(['wider than the viewport',
      `the page is ${root.scrollWidth} px wide in a ${vw} px viewport`]);
  const fits = (r) => r.right <= vw + 1 && r.left >= -1;
  const scroller = new Map();
  const scrolls = (el) => {
    if (!scroller.has(el)) {
      const o = getComputedStyle(el).overflowX;
      scroller.set(el, (o === 'auto' || o === 'scroll') && fits(el.getBoundingClientRect()));
    }
    return scroller.get(el);
  };
  const wide = [];
  for (const el of document.querySelectorAll('main *')) {
    const r = el.getBoundingClientRect();
    if (fits(r) || r.width === 0 || r.height === 0) continue;
    if (wide.some((w) => w.contains(el))) continue;
    let inside = false;
    for (let a = el.parentElement; a && a.tagName !== 'MAIN'; a = a.parentElement)
      if (scrolls(a)) { inside = true; break; }
    if (inside || !el.checkVisibility()) continue;
    wide.push(el);
    const what = el.closest('math') || el;
    const text = what.textContent ? `: "${clip(what.textContent, 80)}"` : '';
    problems.push(['wider than the viewport',
      `<${describe(what)}> spans ${Math.round(r.left)}–${Math.round(r.right)} px, cut off at the ` +
      `${vw} px viewport's edge${text}${near(el)}`]);
  }

  return {problems, height: root.scrollHeight, width: vw};
})()
"""


def fail(msg):
    print(f"check-book-browser: {msg}", file=sys.stderr)
    sys.exit(1)


class BrowserError(Exception):
    """A command failed; `fatal` when the browser is gone or hung, after
    which no other page can be checked."""

    def __init__(self, msg, fatal=False):
        super().__init__(msg)
        self.fatal = fatal


class Browser:
    """Headless Chromium on a DevTools pipe, one tab."""

    def __init__(self, exe):
        self.profile = tempfile.mkdtemp(prefix="check-book-browser-")
        self.log_path = os.path.join(self.profile, "chromium.log")  # its stdout and stderr
        to_r, self.to_w = os.pipe()  # we write, the browser reads (its fd 3)
        self.from_r, from_w = os.pipe()  # the browser writes (its fd 4), we read
        args = [exe, "--headless", "--disable-gpu", "--remote-debugging-pipe",
                f"--user-data-dir={self.profile}", f"--window-size={WIDTH},{HEIGHT}",
                "--no-first-run", "--no-default-browser-check", "--disable-extensions",
                "--disable-background-networking", "--disable-sync", "--mute-audio",
                "--force-device-scale-factor=1", "about:blank"]
        if os.geteuid() == 0:
            # Chromium will not start as root with its sandbox on.
            args.insert(1, "--no-sandbox")

        def child():
            # The browser's ends onto fds 3 and 4; dup2 makes them
            # inheritable. Through fds >= 10 first, so that neither lands on
            # the other's number before it is read.
            r = fcntl.fcntl(to_r, fcntl.F_DUPFD, 10)
            w = fcntl.fcntl(from_w, fcntl.F_DUPFD, 10)
            os.dup2(r, 3)
            os.dup2(w, 4)

        with open(self.log_path, "wb") as out:
            self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=out, stderr=out,
                                         preexec_fn=child, close_fds=False, start_new_session=True)
        os.close(to_r)
        os.close(from_w)
        self.buf = b""
        self.next_id = 0
        self.events = []

    def close(self):
        """Close the browser (Browser.close, then SIGKILL to its whole
        process group for anything left) and remove its profile."""
        if self.proc.poll() is None:
            try:
                self.send("Browser.close", deadline=time.monotonic() + 3)
            except (BrowserError, OSError):
                pass
            try:
                self.proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()
        for fd in (self.to_w, self.from_r):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self.profile, ignore_errors=True)

    def log_tail(self, n=15):
        try:
            lines = Path(self.log_path).read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join("  " + line for line in lines[-n:])

    def _read(self, deadline):
        """One message from the browser, or BrowserError at the deadline."""
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrowserError(f"the browser did not answer in time ({PAGE_TIMEOUT:.0f} s a page)",
                                   fatal=True)
            ready, _, _ = select.select([self.from_r], [], [], left)
            if not ready:
                continue
            chunk = os.read(self.from_r, 1 << 20)
            if not chunk:
                try:
                    status = self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    status = "unknown"
                raise BrowserError(f"the browser exited (status {status})", fatal=True)
            self.buf += chunk
        msg, _, self.buf = self.buf.partition(b"\0")
        return json.loads(msg)

    def send(self, method, params=None, session=None, deadline=None):
        """Send a command and return its result; events that arrive in the
        meantime are kept in self.events."""
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        data = json.dumps(msg).encode() + b"\0"
        try:
            while data:
                data = data[os.write(self.to_w, data):]
        except BrokenPipeError:
            raise BrowserError("the browser exited", fatal=True) from None
        deadline = deadline or time.monotonic() + PAGE_TIMEOUT
        while True:
            reply = self._read(deadline)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})
            if "method" in reply:
                self.events.append(reply)

    def wait_event(self, method, session, deadline):
        """Wait for an event (kept in self.events like the others)."""
        seen = 0
        while True:
            for ev in self.events[seen:]:
                if ev["method"] == method and ev.get("sessionId") == session:
                    return ev
            seen = len(self.events)
            reply = self._read(deadline)
            if "method" in reply:
                self.events.append(reply)


def console_problems(events, session):
    """Console errors, exceptions and error log entries among events."""
    out = []
    for ev in events:
        if ev.get("sessionId") != session:
            continue
        p = ev.get("params", {})
        if ev["method"] == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            text = " ".join(str(a.get("value", a.get("description", a.get("type"))))
                            for a in p.get("args", []))
            out.append(("console error", text))
        elif ev["method"] == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            text = d.get("exception", {}).get("description") or d.get("text", "")
            where = f" ({d['url']}:{d.get('lineNumber', 0) + 1})" if d.get("url") else ""
            out.append(("uncaught exception", text.splitlines()[0] + where if text else where))
        elif ev["method"] == "Log.entryAdded":
            e = p.get("entry", {})
            if e.get("level") == "error":
                url = f" ({e['url']})" if e.get("url") else ""
                out.append((f"browser error ({e.get('source', '?')})", e.get("text", "") + url))
    return out


def find_chromium():
    """The browser to run: $CHROMIUM if set, else `chromium` on PATH."""
    exe = os.environ.get("CHROMIUM")
    if exe:
        found = shutil.which(exe)
        if not found:
            fail(f"CHROMIUM={exe} is not an executable")
        return found
    found = shutil.which("chromium")
    if not found:
        fail("no Chromium to check the book in: the `chromium` command is not on PATH; "
             "install it with scripts/install-browser (which `make deps` runs), or set "
             "CHROMIUM to a Chromium or Chrome binary")
    return found


def shot_name(page):
    """reference/cli.html -> reference-cli.png"""
    return page.replace("/", "-").removesuffix(".html") + ".png"


def pages_of(root):
    return sorted(p for p in root.rglob("*.html")
                  if p.relative_to(root).as_posix() not in SKIP)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("book", nargs="?", default="book/book", help="the built book (default book/book)")
    ap.add_argument("--screenshots", metavar="DIR",
                    help="where to write the screenshots (default: book-screenshots/ beside BOOK)")
    args = ap.parse_args()
    root = Path(args.book).resolve()
    if not (root / "index.html").is_file():
        fail(f"{args.book}: no index.html; was the book built?")
    shots_dir = Path(args.screenshots) if args.screenshots else root.parent / "book-screenshots"
    exe = find_chromium()

    start = time.monotonic()
    pages = pages_of(root)
    missing_shots = [s for s in SCREENSHOTS if not (root / s).is_file()]
    problems = []  # (page, problem, detail)
    shots = []
    checked = 0
    # This run's screenshots only: last run's are removed (a page gone from
    # the book leaves none behind), nothing else in the folder is touched.
    shots_dir.mkdir(parents=True, exist_ok=True)
    for name in SCREENSHOTS:
        (shots_dir / shot_name(name)).unlink(missing_ok=True)
    for s in missing_shots:
        problems.append((s, "missing page", "no such page to take a screenshot of"))

    browser = Browser(exe)
    try:
        try:
            deadline = time.monotonic() + START_TIMEOUT
            targets = browser.send("Target.getTargets", deadline=deadline)["targetInfos"]
            page_target = next((t for t in targets if t["type"] == "page"), None)
            if page_target is None:
                page_target = {"targetId": browser.send("Target.createTarget", {"url": "about:blank"},
                                                        deadline=deadline)["targetId"]}
            session = browser.send("Target.attachToTarget",
                                   {"targetId": page_target["targetId"], "flatten": True},
                                   deadline=deadline)["sessionId"]
            for domain in ("Page", "Runtime", "Log"):
                browser.send(f"{domain}.enable", session=session, deadline=deadline)
        except BrowserError as e:
            fail(f"could not start {exe}: {e}\n{browser.log_tail()}")

        for page in pages:
            rel = page.relative_to(root).as_posix()
            deadline = time.monotonic() + PAGE_TIMEOUT
            browser.events.clear()
            try:
                nav = browser.send("Page.navigate", {"url": page.as_uri()}, session, deadline)
                if nav.get("errorText"):
                    problems.append((rel, "did not load", nav["errorText"]))
                    continue
                browser.wait_event("Page.loadEventFired", session, deadline)
                res = browser.send("Runtime.evaluate", {"expression": CHECK_JS, "awaitPromise": True,
                                                        "returnByValue": True}, session, deadline)
                if "exceptionDetails" in res:
                    d = res["exceptionDetails"]
                    raise BrowserError("the check's script failed: " +
                                       d.get("exception", {}).get("description", d.get("text", "")))
                value = res["result"]["value"]
                problems += [(rel, what, detail) for what, detail in value["problems"]]
                if rel in SCREENSHOTS:
                    height = min(value["height"], MAX_SHOT_HEIGHT)
                    shot = browser.send("Page.captureScreenshot", {
                        "format": "png", "optimizeForSpeed": True, "captureBeyondViewport": True,
                        "clip": {"x": 0, "y": 0, "width": value["width"], "height": height, "scale": 1},
                    }, session, deadline)
                    out = shots_dir / shot_name(rel)
                    out.write_bytes(base64.b64decode(shot["data"]))
                    cut = f", cut at {MAX_SHOT_HEIGHT} of {value['height']} px" if value["height"] > height else ""
                    shots.append(f"{out} ({value['width']}x{height}{cut})")
                # Anything logged until now (late errors too) belongs to this page.
                browser.send("Runtime.evaluate", {"expression": "0"}, session, deadline)
                checked += 1
            except BrowserError as e:
                problems.append((rel, "browser", str(e)))
                if e.fatal:
                    left = len(pages) - pages.index(page) - 1
                    died = browser.proc.poll() is not None
                    tail = browser.log_tail() if died else ""
                    problems.append((rel, "browser", f"stopped here; {left} pages not checked" +
                                     (f"; the browser's last output:\n{tail}" if tail else "")))
                    break
            finally:
                problems += [(rel, what, detail) for what, detail in console_problems(browser.events, session)]
    finally:
        browser.close()

    took = time.monotonic() - start
    for page, what, detail in problems:
        print(f"{page}: {what}: {detail}", file=sys.stderr)
    if shots:
        print("screenshots:\n" + "\n".join("  " + s for s in shots))
    of = f" of {len(pages)}" if checked < len(pages) else ""
    print(f"{checked}{of} pages checked in headless Chromium in {took:.1f} s: {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
