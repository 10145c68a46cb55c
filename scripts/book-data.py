#!/usr/bin/env python3
"""mdBook preprocessor: measured numbers in the book come from data files.

The book quotes measurements; this preprocessor puts them there, so a number
in the prose is always the number in the data the same build made (or in a
committed full run), never a copy that drifts. Two directives:

``{{#value SOURCE EXPR [:FMT]}}``
    SOURCE is ``quick/STUDY`` (the quick run ``scripts/book`` made in
    ``book/src/figures/STUDY/``) or ``full/STUDY`` (the committed full run in
    ``analysis/results/STUDY/``, copied to ``book/src/figures/full/STUDY/``
    by ``scripts/book``). EXPR is arithmetic (``+ - * /``, parentheses,
    numbers) over

    - ``AGG(COLUMN | key=value, key=value)``: AGG is ``one`` (exactly one row
      may match), ``mean``, ``median``, ``min``, ``max``, ``sum`` or
      ``count``, over the rows of ``data.csv`` whose columns equal the given
      values (numbers compare as numbers: ``spp=1`` matches ``1.0``;
      ``key~REGEX`` selects the rows whose column the regular expression
      matches, quoted if it holds ``,`` or ``)``); with no
      ``| …`` every row counts. ``AGG(FILE.csv: COLUMN | …)`` reads another
      CSV file of the run's folder (a study's side table);
    - ``meta(FIELD)``: a number of the run's ``meta.json`` (``wall_time_s``,
      ``runs_total``, ``threads`` …);
    - ``summary(FIGURE, "SERIES")``: the mean a ratio figure recorded for one
      series in ``meta.json`` (its ``summary``);
    - ``out("raylab ARGS…", "REGEX")`` with SOURCE ``cmd``: the number
      that REGEX's first group finds in what the command printed (the
      command runs once per build, from the repository root), for counts
      a page quotes from a command it shows;
    - ``slope(X, Y | key=value, …)``: the least-squares slope of log10 Y
      against log10 X over the matching rows of ``data.csv`` (rows with the
      same X averaged first), the slope a ``fit_slope`` figure's legend shows.

    FMT is a Python format spec (``.2f``, ``.3g``, ``,d``, ``.0%``), or
    ``tex.N`` for ``m\\cdot10^{e}`` with N significant digits (inside maths).
    Outside maths the value becomes a link to the data file whose title holds
    its provenance; inside ``$…$`` it is the bare number.

``{{#assert SOURCE EXPR OP EXPR}}``
    A comparative sentence's evidence: the relation (OP is ``<``, ``<=``,
    ``>`` or ``>=``; both sides are EXPRs as in ``#value``, over the same
    SOURCE) must hold in the data, or the build fails naming the page, the
    line and both values. ``{{#assert SOURCE for each COLUMN | key=value, …:
    EXPR OP EXPR}}`` checks the relation once per distinct value of COLUMN
    among the selected rows, with ``@`` in it standing for the value (a
    claim "on every mesh"). It renders as nothing, so it sits in the sentence
    it backs: "raylab is faster on every mesh{{#assert full/embree-speed
    min(ratio) > 1}}". Quick runs are made anew at every build, so an
    assertion over a quick run may not use a timing: prose compares times
    of committed full runs only.

``{{#measure raylab ARGS…}}`` (on a line of its own)
    Runs the command from the repository root with the book's raylab binary
    (``$RAYLAB``) and shows a "Measure it yourself" box: the command and what
    it printed. Counts are deterministic, so the reader's counts will be these.

``{{#figure SOURCE[,SOURCE] FILE ALT…}}`` (on a line of its own)
    The figure FILE (e.g. ``ratio-resolution.png``) of one run, or of a quick
    and a full run side by side, each captioned with its provenance and
    links to its ``data.csv`` and ``meta.json``.

Directives inside code spans and fenced code blocks are left as written.
A committed full run whose ``meta.json`` says it was made from a work tree
with local changes (``git_dirty``), or from no git revision at all, is
refused: the revision a full run names must be the code that made it.
Every chapter that quotes values ends with a list of the runs they came from
(quick or full run, date, revision, CPU, threads, optimised build) with links
to their ``data.csv`` and ``meta.json``.

The build fails, naming the page, line and reference, when a study, file,
column, field or row does not exist, when ``one`` matches no row or several,
when a timing is quoted from an unoptimised build, or when a command fails.
"""

import csv
import html
import json
import math
import os
import re
import shlex
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "book" / "src" / "figures"
DIRECTIVE = re.compile(r"\{\{#(value|measure|figure|assert)\s+(.*?)\}\}", re.S)
# Columns whose values are times or rates: refused from unoptimised builds.
TIMING = re.compile(r"(_s(_\d+)?$|_s_|_ms$|^time|_time|per_s$|ns_per|speedup|throughput|mrays)")
AGGREGATES = {"one", "mean", "median", "min", "max", "sum", "count"}


class BookError(Exception):
    pass


class Run:
    """One experiment folder: its data.csv, side tables and meta.json."""

    def __init__(self, source):
        kind, _, study = source.partition("/")
        if kind not in ("quick", "full") or not study or "/" in study:
            raise BookError(f"source {source!r}: expected quick/STUDY or full/STUDY")
        self.source = source
        self.kind = kind
        self.dir = FIGURES / study if kind == "quick" else FIGURES / "full" / study
        self.rel = f"figures/{study}" if kind == "quick" else f"figures/full/{study}"
        meta = self.dir / "meta.json"
        if not meta.is_file():
            where = "scripts/book's quick run" if kind == "quick" else f"analysis/results/{study}"
            raise BookError(f"source {source!r}: no {meta.relative_to(ROOT)} (from {where})")
        self.meta = json.loads(meta.read_text())
        if kind == "full" and self.meta.get("git_dirty") is not False:
            why = ("with local changes" if self.meta.get("git_dirty")
                   else "outside a git work tree")
            raise BookError(f"source {source!r}: analysis/results/{study}/meta.json was made {why} "
                            f"(revision {self.meta.get('git_revision', 'unknown')[:10]}); a committed "
                            f"full run must come from a clean tree of the revision it names: run it "
                            f"again (analysis/results/README.md)")
        self.tables = {}

    def table(self, name):
        if name not in self.tables:
            path = self.dir / name
            if not path.is_file():
                raise BookError(f"{self.source}: no file {name} in {self.dir.relative_to(ROOT)}")
            with path.open(newline="") as f:
                rows = list(csv.DictReader(f))
            self.tables[name] = rows
        return self.tables[name]

    def provenance(self):
        m = self.meta
        rev = m.get("git_revision", "unknown")[:10]
        if m.get("git_dirty"):
            rev += " (with local changes)"
        build = "optimised build" if m.get("optimised") else "UNOPTIMISED build"
        date = (m.get("started_utc") or "")[:10]
        return (
            f"{'quick' if m.get('quick') else 'full'} run of analysis/{m.get('name')}.toml, {date}, "
            f"revision {rev}, {m.get('cpu_model')}, {m.get('threads')} threads, {build}"
        )


def same(a, b):
    if a == b:
        return True
    try:
        return float(a) == float(b)
    except ValueError:
        return False


ASSERTIONS = []  # (page:line, relation) of every assertion that held
def matches(cell, condition):
    """A selector's condition (``=VALUE`` or ``~REGEX``) on one cell."""
    if condition.startswith("~"):
        return re.search(condition[1:], cell) is not None
    return same(cell, condition[1:])


OUTPUTS = {}  # command line -> what it printed: each command runs once per build


def run_command(args, raylab):
    """Run a raylab command line from the repository root (once per build)."""
    if args in OUTPUTS:
        return OUTPUTS[args]
    words = shlex.split(args)
    if not words or words[0] != "raylab":
        raise BookError(f"runs raylab commands only, got {args!r}")
    (ROOT / "out").mkdir(exist_ok=True)  # commands in the book write under out/
    try:
        done = subprocess.run([raylab] + words[1:], cwd=ROOT, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        raise BookError(f"`{args}` took over 120 s")
    if done.returncode != 0:
        raise BookError(f"`{args}` failed (exit {done.returncode}):\n{done.stderr}")
    OUTPUTS[args] = (done.stdout + done.stderr).rstrip()
    return OUTPUTS[args]


class Commands:
    """The source `cmd`: numbers printed by raylab commands run at build time."""

    source = "cmd"

    def __init__(self, raylab):
        self.raylab = raylab

    def provenance(self):
        return "printed by the raylab this book was built with, running the command quoted on the page"


class Parser:
    """Recursive descent over the tokens of one EXPR."""

    TOKEN = re.compile(r'\s*(?:(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)|("[^"]*")|([A-Za-z_][\w.:+\-]*)|(.))')

    def __init__(self, text, run):
        self.text = text
        self.run = run
        self.columns = []
        self.pos = 0

    def peek(self):
        m = self.TOKEN.match(self.text, self.pos)
        if not m or m.end() == self.pos:
            return None, None
        for kind, group in zip(("num", "str", "name", "op"), m.groups()):
            if group is not None:
                return kind, group
        return None, None

    def take(self, expected=None):
        kind, tok = self.peek()
        if tok is None:
            raise BookError(f"unexpected end of expression {self.text!r}")
        if expected is not None and tok != expected:
            raise BookError(f"expected {expected!r} at {tok!r} in {self.text!r}")
        self.pos = self.TOKEN.match(self.text, self.pos).end()
        return kind, tok

    def raw_until(self, stops):
        """Text up to (not including) the first of `stops` outside quotes."""
        start = self.pos
        quoted = False
        while self.pos < len(self.text):
            c = self.text[self.pos]
            if c == '"':
                quoted = not quoted
            elif not quoted and c in stops:
                break
            self.pos += 1
        return self.text[start : self.pos].strip()

    def parse(self):
        value = self.expr()
        if self.peek()[1] is not None:
            raise BookError(f"unexpected {self.peek()[1]!r} in {self.text!r}")
        return value

    def expr(self):
        value = self.term()
        while self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            rhs = self.term()
            value = value + rhs if op == "+" else value - rhs
        return value

    def term(self):
        value = self.factor()
        while self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            rhs = self.factor()
            if op == "/" and rhs == 0:
                raise BookError(f"division by zero in {self.text!r}")
            value = value * rhs if op == "*" else value / rhs
        return value

    def factor(self):
        kind, tok = self.peek()
        if tok == "-":
            self.take()
            return -self.factor()
        if tok == "(":
            self.take()
            value = self.expr()
            self.take(")")
            return value
        if kind == "num":
            self.take()
            return float(tok)
        if kind == "name":
            self.take()
            self.take("(")
            if tok in AGGREGATES:
                return self.aggregate(tok)
            if tok == "meta":
                return self.meta_field()
            if tok == "summary":
                return self.summary()
            if tok == "slope":
                return self.slope()
            if tok == "out":
                return self.output()
            raise BookError(f"unknown function {tok!r} in {self.text!r} (aggregates: "
                            f"{', '.join(sorted(AGGREGATES))}; meta; summary; slope)")
        raise BookError(f"unexpected {tok!r} in {self.text!r}")

    def selector(self):
        """``| key=value, …)``: the pairs, up to and including the ``)``."""
        selector = []
        if self.peek()[1] == "|":
            self.pos += self.text[self.pos :].index("|") + 1
            while True:
                item = self.raw_until(",)")
                m = re.match(r'\s*([^=~]+?)\s*([=~])\s*(.*)$', item, re.S)
                if not m:
                    raise BookError(f"selector {item!r} in {self.text!r}: expected key=value or key~regex")
                key, op, value = m.group(1), m.group(2), m.group(3).strip().strip('"')
                if op == "~":
                    try:
                        re.compile(value)
                    except re.error as e:
                        raise BookError(f"selector {item!r} in {self.text!r}: bad regex: {e}")
                selector.append((key, op + value))
                if self.peek()[1] != ",":
                    break
                self.take(",")
        self.take(")")
        return selector

    def aggregate(self, agg):
        spec = self.raw_until("|)")
        file, column = "data.csv", spec
        if ":" in spec:
            file, column = (s.strip() for s in spec.split(":", 1))
        selector = self.selector()
        rows = self.run.table(file)
        known = rows[0].keys() if rows else []
        for name in [column] + [k for k, _ in selector]:
            if name not in known:
                raise BookError(f"{self.run.source}: no column {name!r} in {file} "
                                f"(columns: {', '.join(known)})")
        if TIMING.search(column) and not self.run.meta.get("optimised"):
            raise BookError(f"{self.run.source}: {column!r} is a timing and the run's build was "
                            f"not optimised; timings in the book come from release builds")
        self.columns.append(column)
        chosen = [r for r in rows if all(matches(r[k], v) for k, v in selector)]
        where = ", ".join(f"{k}{v}" for k, v in selector) or "all rows"
        if agg == "count":
            return float(len(chosen))
        if not chosen:
            raise BookError(f"{self.run.source}: no row of {file} has {where}")
        if agg == "one" and len(chosen) != 1:
            raise BookError(f"{self.run.source}: one({column} | {where}) matches {len(chosen)} rows of {file}; "
                            f"add keys to the selector or use an aggregate")
        try:
            values = [float(r[column]) for r in chosen]
        except ValueError:
            raise BookError(f"{self.run.source}: column {column!r} of {file} is not numeric where {where}")
        if any(not math.isfinite(v) for v in values):
            raise BookError(f"{self.run.source}: {column!r} is not finite where {where}")
        return {
            "one": lambda v: v[0],
            "mean": statistics.fmean,
            "median": statistics.median,
            "min": min,
            "max": max,
            "sum": math.fsum,
        }[agg](values)

    def slope(self):
        """The log–log least-squares slope, as crates/lab/src/experiment/figures/mod.rs's
        fitted_slope computes it for a figure's legend."""
        spec = self.raw_until("|)")
        if spec.count(",") != 1:
            raise BookError(f"slope({spec}) in {self.text!r}: expected slope(X, Y | key=value, …)")
        x_col, y_col = (c.strip() for c in spec.split(","))
        selector = self.selector()
        rows = self.run.table("data.csv")
        known = rows[0].keys() if rows else []
        for name in [x_col, y_col] + [k for k, _ in selector]:
            if name not in known:
                raise BookError(f"{self.run.source}: no column {name!r} in data.csv "
                                f"(columns: {', '.join(known)})")
        for col in (x_col, y_col):
            if TIMING.search(col) and not self.run.meta.get("optimised"):
                raise BookError(f"{self.run.source}: {col!r} is a timing and the run's build was "
                                f"not optimised; timings in the book come from release builds")
        self.columns += [x_col, y_col]
        by_x = {}
        for r in rows:
            if all(matches(r[k], v) for k, v in selector):
                try:
                    x, y = float(r[x_col]), float(r[y_col])
                except ValueError:
                    continue
                if x > 0 and y > 0 and math.isfinite(x) and math.isfinite(y):
                    by_x.setdefault(x, []).append(y)
        uv = [(math.log10(x), math.log10(statistics.fmean(ys))) for x, ys in by_x.items()]
        where = ", ".join(f"{k}{v}" for k, v in selector) or "all rows"
        if len(uv) < 2:
            raise BookError(f"{self.run.source}: slope({x_col}, {y_col} | {where}) has fewer than "
                            f"two distinct positive {x_col} values")
        mu = statistics.fmean(u for u, _ in uv)
        mv = statistics.fmean(v for _, v in uv)
        sxy = math.fsum((u - mu) * (v - mv) for u, v in uv)
        return sxy / math.fsum((u - mu) ** 2 for u, _ in uv)

    def output(self):
        """out("raylab ARGS…", "REGEX"): the number REGEX's first group (or
        match) finds in what the command printed."""
        if not isinstance(self.run, Commands):
            raise BookError(f"out(…) needs the source cmd, not {self.run.source}")
        args = self.raw_until(",").strip()
        self.take(",")
        pattern = self.raw_until(")").strip()
        self.take(")")
        if not (len(args) > 1 and args[0] == args[-1] == '"' and len(pattern) > 1 and pattern[0] == pattern[-1] == '"'):
            raise BookError(f'expected out("raylab ARGS", "REGEX") in {self.text!r}')
        args, pattern = args[1:-1], pattern[1:-1]
        printed = run_command(args, self.run.raylab)
        m = re.search(pattern, printed)
        if not m:
            raise BookError(f"`{args}` printed nothing matching {pattern!r}:\n{printed}")
        found = (m.group(1) if m.groups() else m.group(0)).replace(",", "").replace(" ", "")
        try:
            value = float(found)
        except ValueError:
            raise BookError(f"{pattern!r} found {found!r} in the output of `{args}`: not a number")
        self.columns.append(f"the output of `{args}`")
        return value

    def meta_field(self):
        field = self.raw_until(")")
        self.take(")")
        value = self.run.meta
        for part in field.split("."):
            if not isinstance(value, dict) or part not in value:
                raise BookError(f"{self.run.source}: meta.json has no field {field!r}")
            value = value[part]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise BookError(f"{self.run.source}: meta.json's {field!r} is not a number ({value!r})")
        if TIMING.search(field) and not self.run.meta.get("optimised"):
            raise BookError(f"{self.run.source}: {field!r} is a timing from an unoptimised build")
        self.columns.append(field)
        return float(value)

    def summary(self):
        figure = self.raw_until(",")
        self.take(",")
        series = self.raw_until(")").strip('"')
        self.take(")")
        for s in self.run.meta.get("summary", []):
            if s["figure"] == figure:
                for entry in s["series"]:
                    if entry["label"] == series:
                        if entry.get("measured") and not self.run.meta.get("optimised"):
                            raise BookError(f"{self.run.source}: summary of {figure} is a timing "
                                            f"from an unoptimised build")
                        self.columns.append(f"summary of {figure}")
                        return float(entry["mean"])
                labels = ", ".join(repr(e["label"]) for e in s["series"])
                raise BookError(f"{self.run.source}: figure {figure!r} has no series {series!r} ({labels})")
        figures = ", ".join(s["figure"] for s in self.run.meta.get("summary", []))
        raise BookError(f"{self.run.source}: meta.json has no summary of figure {figure!r} ({figures})")


RELATIONS = {
    "<=": lambda a, b: a <= b,
    ">=": lambda a, b: a >= b,
    "<": lambda a, b: a < b,
    ">": lambda a, b: a > b,
}


def split_relation(text):
    """EXPR OP EXPR: the two sides and OP, the one relation outside
    parentheses and quotes (selectors' ``key=value`` are inside)."""
    depth, quoted, found = 0, False, []
    i = 0
    while i < len(text):
        c = text[i]
        if c == '"':
            quoted = not quoted
        elif not quoted and c == "(":
            depth += 1
        elif not quoted and c == ")":
            depth -= 1
        elif not quoted and depth == 0 and c in "<>":
            op = text[i : i + 2] if text[i + 1 : i + 2] == "=" else c
            found.append((i, op))
            i += len(op)
            continue
        i += 1
    if len(found) != 1:
        raise BookError(f"expected EXPR OP EXPR with one of {', '.join(RELATIONS)} in {text!r}")
    i, op = found[0]
    return text[:i].strip(), op, text[i + len(op) :].strip()


# The relation follows the first ": " (a colon and a space; a value such as
# icosphere:7 has no space after its colon).
FOR_EACH = re.compile(r"for\s+each\s+(\w+)\s*(?:\|(.*?))?:\s+(.*)$", re.S)


def check_assertion(body, runs, raylab):
    """``{{#assert SOURCE EXPR OP EXPR}}``: raise unless the relation holds.
    ``{{#assert SOURCE for each COLUMN | key=value, …: EXPR OP EXPR}}``: for
    every distinct value of COLUMN among the selected rows of data.csv, with
    ``@`` in the relation replaced by that value."""
    source, _, rest = body.partition(" ")
    if source not in runs:
        runs[source] = Commands(raylab) if source == "cmd" else Run(source)
    run = runs[source]
    each = FOR_EACH.match(rest)
    if each:
        column, where, relation = each.group(1), each.group(2) or "", each.group(3)
        if not isinstance(run, Run):
            raise BookError("for each needs a run's data.csv, not cmd")
        parser = Parser(f"count({column} | {where})" if where.strip() else f"count({column})", run)
        parser.parse()
        rows = run.table("data.csv")
        selector = Parser(f"| {where})" if where.strip() else ")", run).selector()
        keys = list(dict.fromkeys(r[column] for r in rows if all(matches(r[k], v) for k, v in selector)))
        if not keys:
            raise BookError(f"{source}: no rows for each {column} where {where.strip() or 'all rows'}")
        for key in keys:
            if "," in key or ")" in key or '"' in key:
                raise BookError(f"{source}: {column} value {key!r} cannot stand in a selector")
            check_relation(relation.replace("@", key), source, run, f" for {column}={key}")
        return run
    check_relation(rest, source, run, "")
    return run


def check_relation(text, source, run, label):
    lhs, op, rhs = split_relation(text)
    values, columns = [], []
    for side in (lhs, rhs):
        parser = Parser(side, run)
        values.append(parser.parse())
        columns += parser.columns
    timed = [c for c in columns if TIMING.search(c)]
    if getattr(run, "kind", None) == "quick" and timed:
        raise BookError(f"asserts over {', '.join(dict.fromkeys(timed))} of a quick run: timings of "
                        f"quick runs change at every build; compare a committed full run's")
    if not RELATIONS[op](*values):
        raise BookError(f"the claim no longer holds{label}: {lhs} = {values[0]:.6g} is not {op} "
                        f"{rhs} = {values[1]:.6g} in {source}; the sentence it backs must change")


def format_value(value, fmt):
    if fmt.startswith("tex"):
        digits = int(fmt[4:] or 2) if fmt[3:4] == "." else 2
        if value == 0:
            return "0"
        exp = math.floor(math.log10(abs(value)))
        mant = value / 10**exp
        if round(abs(mant), digits - 1) >= 10:
            mant, exp = mant / 10, exp + 1
        m = f"{mant:.{digits - 1}f}"
        return m if exp == 0 else f"{m}\\cdot{{10}}^{{{exp}}}"
    try:
        if fmt.endswith("d"):
            return format(int(round(value)), fmt)
        return format(value, fmt or "g")
    except ValueError as e:
        raise BookError(f"format {fmt!r}: {e}")


def spans(text):
    """(start, end) of every $…$ / $$…$$ span, and of every code span and
    fenced block (where directives are shown as written, not run)."""
    maths, code = [], []
    for m in re.finditer(r"```.*?```|`[^`\n]*`|\$\$.*?\$\$|\$[^$\n]+?\$", text, re.S):
        (maths if m.group(0).startswith("$") else code).append((m.start(), m.end()))
    return maths, code


def measure(args, raylab):
    output = run_command(args, raylab)
    timed = re.search(r"\btime\b|Mrays/s|\d s\b", output)
    note = ("Counts are exact: yours will be these. Times depend on the machine."
            if timed else "The output is deterministic: yours will be this.")
    return (
        "\n<div class=\"measure-box\">\n\n"
        "**Measure it yourself** (from the repository root; "
        "[how to build raylab](getting-started.md)):\n\n"
        f"```console\n$ {args}\n{output}\n```\n\n{note}\n\n</div>\n"
    )


def figure(body, runs, prefix, used):
    sources, _, rest = body.partition(" ")
    file, _, alt = rest.partition(" ")
    if not file:
        raise BookError("expected {{#figure SOURCE[,SOURCE] FILE ALT}}")
    parts = []
    names = sources.split(",")
    width = "100%" if len(names) == 1 else f"{100 / len(names) - 1:.0f}%"
    for source in names:
        if source not in runs:
            runs[source] = Run(source)
        run = runs[source]
        if not (run.dir / file).is_file():
            drawn = sorted(p.name for p in run.dir.iterdir() if p.suffix == ".png")
            drawn = ", ".join(drawn[:12]) + (f" … and {len(drawn) - 12} more" if len(drawn) > 12 else "")
            raise BookError(f"{source}: no figure {file} in {run.dir.relative_to(ROOT)} (figures: {drawn})")
        used[source] = run
        href = f"{prefix}{run.rel}"
        caption = (f"{html.escape(run.provenance())}; "
                   f'<a href="{href}/data.csv">data.csv</a>, <a href="{href}/meta.json">meta.json</a>')
        parts.append(
            f'<figure style="display:inline-block; width:{width}; margin:0 0.5%; vertical-align:top">'
            f'<img src="{href}/{file}" alt="{html.escape(alt, quote=True)}" style="width:100%">'
            f'<figcaption style="font-size:0.8em">{caption}</figcaption></figure>'
        )
    return "\n<div class=\"measured-figure\">" + "".join(parts) + "</div>\n"


def depth_prefix(path):
    return "../" * (len(Path(path).parts) - 1)


def process(content, path, raylab, runs):
    used = {}
    maths, code = spans(content)
    prefix = depth_prefix(path)

    def replace(m):
        if any(a <= m.start() < b for a, b in code):
            return m.group(0)
        line = content.count("\n", 0, m.start()) + 1
        where = f"book/src/{path}:{line}"
        kind, body = m.group(1), " ".join(m.group(2).split())
        try:
            if kind == "measure":
                out = measure(body, raylab)
                return out.replace("](getting-started.md)", f"]({prefix}getting-started.md)")
            if kind == "figure":
                return figure(body, runs, prefix, used)
            if kind == "assert":
                run = check_assertion(body, runs, raylab)
                ASSERTIONS.append((where, body))
                if isinstance(run, Run):
                    used[run.source] = run
                return ""
            source, _, rest = body.partition(" ")
            expr, fmt = rest, ""
            fm = re.search(r"\s:(\S+)$", rest)
            if fm:
                expr, fmt = rest[: fm.start()], fm.group(1)
            if source not in runs:
                runs[source] = Commands(raylab) if source == "cmd" else Run(source)
            run = runs[source]
            parser = Parser(expr, run)
            text = format_value(parser.parse(), fmt)
        except BookError as e:
            raise BookError(f"{where}: {m.group(0)}: {e}") from None
        if any(a <= m.start() < b for a, b in maths):
            return text
        title = html.escape(f"{', '.join(dict.fromkeys(parser.columns))} — {run.provenance()}", quote=True)
        if isinstance(run, Commands):
            return f'<span class="measured" title="{title}">{text}</span>'
        used[source] = run
        return f'<a class="measured" href="{prefix}{run.rel}/data.csv" title="{title}">{text}</a>'

    content = DIRECTIVE.sub(replace, content)
    if used:
        lines = ["", "", "---", "", "<div class=\"provenance\">", "",
                 "**Where the numbers on this page come from.** Each measured number links to its "
                 "data; hover over it for the column and the run. The runs:", ""]
        for source, run in sorted(used.items()):
            lines.append(f"- `{source}`: {run.provenance()}; "
                         f"[data.csv]({prefix}{run.rel}/data.csv), [meta.json]({prefix}{run.rel}/meta.json)")
        lines += ["", "</div>", ""]
        content = content.rstrip("\n") + "\n" + "\n".join(lines)
    return content


def chapters(items):
    for item in items:
        if isinstance(item, dict) and "Chapter" in item:
            yield item["Chapter"]
            yield from chapters(item["Chapter"].get("sub_items", []))


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "supports":
        return 0
    context, book = json.load(sys.stdin)
    raylab = os.environ.get("RAYLAB", str(ROOT / "target" / "release" / "raylab"))
    raylab = str((ROOT / raylab).resolve()) if not os.path.isabs(raylab) else raylab
    runs = {}
    errors = []
    items = book.get("items", book.get("sections", []))
    for chapter in chapters(items):
        if not chapter.get("path"):
            continue
        try:
            chapter["content"] = process(chapter["content"], chapter["path"], raylab, runs)
        except BookError as e:
            errors.append(str(e))
    if errors:
        for e in errors:
            print(f"book-data: {e}", file=sys.stderr)
        return 1
    print(f"book-data: {len(ASSERTIONS)} claims asserted over data, all hold", file=sys.stderr)
    json.dump(book, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
