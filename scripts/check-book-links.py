#!/usr/bin/env python3
"""Check a built mdBook, page by page:

- every internal link and image must resolve to a file of the book (and a
  link's #fragment to an id on the target page); external links (http:,
  https:, mailto:) are not fetched;
- no TeX may be left outside rendered maths: text outside <math>, <code>
  and <pre> holding a TeX command (\\frac, \\cdot…), a $…$ pair, ^{ or _{;
  and no HTML tag a browser ends maths at (<em>, <p>…) inside <math>, which
  is how Markdown emphasis in an equation used to cut it short;
- a plotted figure (a PNG with an SVG beside it) must not have ink in its
  outermost pixels at the top, where the title is: a title wider than the
  canvas is cut off there. (The plotting layer shrinks text to fit and
  fails otherwise; this catches a figure drawn some other way.)

Exit status 1, with each problem listed, when any is found."""

import re
import struct
import sys
import zlib
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

# Text-level HTML tags at which an HTML parser leaves MathML ("breakout"
# tags of the HTML standard's foreign-content rules).
BREAKOUT = set(
    "b big blockquote body br center code dd div dl dt em embed h1 h2 h3 h4 h5 h6 "
    "head hr i img li listing menu meta nobr ol p pre ruby s small span strike "
    "strong sub sup table tt u ul var".split()
)
SKIP = {"code", "pre", "script", "style", "math", "svg", "title"}
TEX = re.compile(
    r"\\[A-Za-z]{2,}|\$[^$\s][^$]*\$|\^\{|_\{"
)


class Refs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs = []  # (attribute, value, line)
        self.ids = set()
        self.tex = []  # (line, what)
        self.open = []  # open elements that hide text from the TeX check

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name == "id" and value:
                self.ids.add(value)
            if value and ((tag == "a" and name == "href") or (tag == "img" and name == "src")):
                self.refs.append((name, value, self.getpos()[0]))
        if "math" in self.open and tag in BREAKOUT:
            self.tex.append((self.getpos()[0], f"<{tag}> inside maths ends the maths there"))
        if tag in SKIP and tag not in ("img", "br"):
            self.open.append(tag)

    def handle_endtag(self, tag):
        if tag in SKIP and tag in self.open:
            while self.open and self.open.pop() != tag:
                pass

    def handle_data(self, data):
        if self.open:
            return
        for m in TEX.finditer(data):
            line = self.getpos()[0] + data.count("\n", 0, m.start())
            self.tex.append((line, f"TeX outside maths: {data[max(0, m.start() - 20):m.end() + 20].strip()!r}"))


def png_top_rows(path, rows):
    """The first `rows` rows of an 8-bit RGB or RGBA PNG as lists of
    (r, g, b) tuples, or None for a PNG of another kind."""
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    pos, idat, header = 8, [], None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + length
    if header is None:
        return None
    width, height, depth, colour, _, _, interlace = header
    channels = {2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace:
        return None
    stride = width * channels
    rows = min(rows, height)
    raw = zlib.decompressobj().decompress(b"".join(idat), rows * (stride + 1))
    out, prev = [], bytearray(stride)
    for y in range(rows):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out.append([tuple(line[x * channels:x * channels + 3]) for x in range(width)])
        prev = line
    return out


def clipped_title(png):
    """Whether a plotted figure has ink in its outermost two columns within
    its top 90 rows (the title band)."""
    rows = png_top_rows(png, 90)
    if not rows:
        return False
    return any(min(px) < 200 for row in rows for px in row[:2] + row[-2:])


def parse(path):
    p = Refs()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def main(root):
    root = Path(root)
    if not (root / "index.html").is_file():
        print(f"{root}: no index.html; was the book built?", file=sys.stderr)
        return 1
    pages = {p.resolve(): parse(p) for p in root.rglob("*.html")}
    broken = []
    checked = 0
    figures = set()
    for page, refs in pages.items():
        for line, what in refs.tex:
            broken.append(f"{page.relative_to(root.resolve())}:{line}: {what}")
    for page, refs in pages.items():
        for attr, value, line in refs.refs:
            url = urlsplit(value)
            if url.scheme or value.startswith("//"):
                continue
            checked += 1
            target = (page.parent / unquote(url.path)).resolve() if url.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                broken.append(f"{page.relative_to(root.resolve())}:{line}: {attr}={value!r}: no such file")
                continue
            if attr == "src" and target.suffix == ".png" and target.with_suffix(".svg").is_file():
                figures.add(target)
            if url.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else parse(target).ids
                if unquote(url.fragment) not in ids:
                    broken.append(f"{page.relative_to(root.resolve())}:{line}: {attr}={value!r}: no id {url.fragment!r}")
    for fig in sorted(figures):
        if clipped_title(fig):
            broken.append(f"{fig.relative_to(root.resolve())}: ink at the figure's left or right edge "
                          "in the title band: a clipped title?")
    for b in broken:
        print(b, file=sys.stderr)
    print(f"{checked} internal links and images in {len(pages)} pages, {len(figures)} plotted "
          f"figures: {len(broken)} problems")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "book/book"))
