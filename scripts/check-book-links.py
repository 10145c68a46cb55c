#!/usr/bin/env python3
"""Check a built mdBook: every internal link and image of every page must
resolve to a file of the book (and a link's #fragment to an id on the
target page). External links (http:, https:, mailto:) are not fetched.
Exit status 1, with each broken reference listed, when any is broken."""

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit


class Refs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs = []  # (attribute, value, line)
        self.ids = set()

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name == "id" and value:
                self.ids.add(value)
            if value and ((tag == "a" and name == "href") or (tag == "img" and name == "src")):
                self.refs.append((name, value, self.getpos()[0]))


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
            if url.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else parse(target).ids
                if unquote(url.fragment) not in ids:
                    broken.append(f"{page.relative_to(root.resolve())}:{line}: {attr}={value!r}: no id {url.fragment!r}")
    for b in broken:
        print(b, file=sys.stderr)
    print(f"{checked} internal links and images in {len(pages)} pages: {len(broken)} broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "book/book"))
