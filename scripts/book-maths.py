#!/usr/bin/env python3
"""mdBook preprocessor, run after mdbook-katex: protect the rendered maths
from the Markdown pass that follows.

mdbook-katex replaces `$…$` and `$$…$$` with MathML, which keeps the TeX
source in an `<annotation>`. mdBook then renders the page as Markdown, and
that pass reads the text inside the MathML too: an underscore pair in the
TeX (`\\mathbf{r}_j … L_{\\text{reflected}}`) becomes `<em>`, a backslash
escape loses its backslash. An HTML parser ends a `<math>` element at an
`<em>`, so the rest of the equation showed as raw TeX after it. Here every
character Markdown could act on, inside a `<math>` element, is written as a
character reference, which Markdown leaves alone and a browser reads as the
character itself: the maths and its annotation come out as KaTeX made them.

One rewrite of KaTeX's MathML: a prime is a superscript there
(`<msup><mi>f</mi><mo>′</mo></msup>`), which Chromium draws as a tiny mark
far above the letter. A superscript of primes only becomes a plain row,
letter then primes, which every browser draws as f′.

Usage (book.toml): [preprocessor.maths] command = "python3 scripts/book-maths.py",
after = ["katex"]. `scripts/check-book-links.py` checks the built pages
for TeX left outside rendered maths.
"""

import json
import re
import sys

MATH = re.compile(r"<math\b.*?</math>", re.S)
TEXT = re.compile(r">([^<]+)<")
ACTIVE = {c: f"&#{ord(c)};" for c in "\\_*`[]~$"}
# A base without children (<mi>, <mn>, <mo>) and a superscript of primes only:
# one <mo>, or an <mrow> of them.
PRIME = '<mo[^>]*>[′″‴]</mo>'
PRIMED = re.compile(
    r"<msup>(<m[ino]\b[^>]*>[^<]*</m[ino]>)(" + PRIME + r"|<mrow>(?:" + PRIME + r")+</mrow>)</msup>"
)


def unraise_primes(maths):
    def row(m):
        primes = re.findall(r"[′″‴]", m.group(2))
        return "<mrow>" + m.group(1) + "".join(f'<mo lspace="0em" rspace="0em">{p}</mo>' for p in primes) + "</mrow>"

    return PRIMED.sub(row, maths)


def protect_text(m):
    return ">" + "".join(ACTIVE.get(c, c) for c in m.group(1)) + "<"


def protect(content):
    return MATH.sub(lambda m: TEXT.sub(protect_text, unraise_primes(m.group(0))), content)


def walk(items):
    for item in items:
        chapter = item.get("Chapter") if isinstance(item, dict) else None
        if chapter:
            chapter["content"] = protect(chapter["content"])
            walk(chapter.get("sub_items", []))


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "supports":
        sys.exit(0)
    _context, book = json.load(sys.stdin)
    walk(book.get("sections", book.get("items", [])))
    json.dump(book, sys.stdout)


if __name__ == "__main__":
    main()
