"""Run the ```python blocks of README.md and docs/*.md and check what they print.

Collection
    Every fenced block whose info string is ``python`` in README.md and docs/*.md
    (not docs/notes/) is one test item, with the id ``<file>:<k>`` (k = 1, 2, ... in the
    file's order). The blocks of one file run in order in one namespace (later blocks use
    the names of earlier ones), in a temporary working directory of that file (so
    ``out/...`` paths do not touch the repository), with MPLBACKEND=Agg. Selecting one
    item (``-k "user_guide.md:3"``) first runs the file's earlier blocks.

    Blocks that are not Python (shell commands, output) use another fence language
    (``sh``, ``text``). A Python block that cannot run in the test suite is marked by an
    HTML comment on the line(s) right before its fence, with the reason::

        <!-- docs-test: skip <why> -->

    Use it rarely; later blocks must not depend on a skipped block's names.

Expected output: ``# ->`` comments
    A top-level statement whose lines carry a comment starting with ``# ->`` must print
    what that comment says; an optional note after a semicolon is not compared::

        print(crit.kind, crit.mass_flow)    # -> flutter 25.0089106; kg/s

    The printed text and the expectation are split into tokens (numbers, words,
    brackets and other single characters). Words and punctuation must be equal; a
    number must round to the digits shown, i.e. lie within half a unit of the last
    printed digit of the expected number (``13.719`` accepts 13.7185 ... 13.7195,
    ``3.2e-3`` accepts 3.15e-3 ... 3.25e-3, ``0`` accepts |x| <= 0.5). Whitespace and
    line breaks (numpy's array wrapping) do not matter. Statements without a ``# ->``
    comment may print anything. A compound statement (``try``/``except``, ``for``) is one
    statement: its whole output is compared with its one ``# ->`` comment.
"""
import ast
import contextlib
import io
import math
import re
import tokenize
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOC_FILES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))  # glob("*.md"): not docs/notes/

FENCE = re.compile(r"^(`{3,}|~{3,})\s*([^\s`]*)")
SKIP = re.compile(r"^<!--\s*docs-test:\s*skip\b\s*(.*?)\s*-->\s*$")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
TOKEN = re.compile(NUMBER.pattern + r"|[A-Za-z_][\w.]*|\S")


@dataclass
class Block:
    path: Path
    index: int  # 1-based, among the file's python blocks
    line: int  # line of the opening fence (1-based)
    source: str
    skip: Optional[str] = None  # reason, if marked

    @property
    def id(self) -> str:
        return f"{self.path.name}:{self.index}"


def python_blocks(path: Path) -> List[Block]:
    """The ```python blocks of a markdown file, with their skip markers."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang = m.group(1), m.group(2).lower()
        start = i
        i += 1
        body = []
        closing = re.compile(rf"\s*{re.escape(fence[0])}{{{len(fence)},}}\s*")
        while i < len(lines) and not closing.fullmatch(lines[i]):
            body.append(lines[i])
            i += 1
        i += 1  # closing fence
        if lang != "python":
            continue
        skip, j = None, start - 1
        while j >= 0 and not lines[j].strip():
            j -= 1
        if j >= 0:
            s = SKIP.match(lines[j].strip())
            if s:
                skip = s.group(1) or "(no reason given)"
        blocks.append(Block(path, len(blocks) + 1, start + 1, "\n".join(body) + "\n", skip))
    return blocks


BLOCKS = [b for p in DOC_FILES for b in python_blocks(p)]


# ---------------------------------------------------------------------------------------
# expected output

def expectations(source: str) -> Dict[int, str]:
    """Line number (1-based, in the block) -> expected output of its ``# ->`` comment."""
    out = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT and tok.string.startswith("# ->"):
            out[tok.start[0]] = tok.string[4:].split(";", 1)[0].strip()
    return out


def _unit(text: str) -> float:
    """Half a unit of the last digit of a number as written."""
    mant, _, exp = text.lower().partition("e")
    decimals = len(mant.split(".", 1)[1]) if "." in mant else 0
    return 0.5 * 10.0 ** (int(exp or 0) - decimals)


def compare(printed: str, expected: str) -> Optional[str]:
    """None if ``printed`` matches ``expected`` (see the module docstring), else why not."""
    got, want = TOKEN.findall(printed), TOKEN.findall(expected)
    if len(got) != len(want):
        return f"{len(got)} tokens printed, {len(want)} expected"
    for g, w in zip(got, want):
        if NUMBER.fullmatch(w):
            if not NUMBER.fullmatch(g):
                return f"{g!r} printed where the number {w} is expected"
            x, e = float(g), float(w)
            tol = _unit(w) * (1 + 1e-9) + 1e-12 * abs(e)
            if not (math.isfinite(x) and abs(x - e) <= tol):
                return f"{g} printed, {w} expected (+- {_unit(w):.1g})"
        elif g != w:
            return f"{g!r} printed where {w!r} is expected"
    return None


# ---------------------------------------------------------------------------------------
# running

@dataclass
class FileRun:
    """State of one documentation file's run: namespace, working directory, blocks done."""

    workdir: Path
    namespace: dict = field(default_factory=lambda: {"__name__": "__docs__"})
    done: int = 0  # blocks 1..done have been run (or skipped)


def run_block(block: Block, run: FileRun, monkeypatch) -> List[str]:
    """Execute one block statement by statement; returns the mismatches of ``# ->`` lines."""
    monkeypatch.chdir(run.workdir)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    expected = expectations(block.source)
    tree = ast.parse(block.source, filename=block.id)
    problems = []
    try:
        for stmt in tree.body:
            code = compile(ast.Module(body=[stmt], type_ignores=[]), f"<{block.id} (line {block.line})>", "exec")
            mine = {ln: e for ln, e in expected.items() if stmt.lineno <= ln <= stmt.end_lineno}
            if not mine:
                exec(code, run.namespace)
                continue
            assert len(mine) == 1, f"{block.id}: one '# ->' comment per statement (lines {sorted(mine)})"
            (ln, want), = mine.items()
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(code, run.namespace)
            printed = buf.getvalue()
            print(printed, end="")
            why = compare(printed, want)
            if why:
                doc_line = block.line + ln
                problems.append(f"{block.path.name}, line {doc_line}: {why}\n    printed:  {printed.strip()}"
                                f"\n    expected: {want}")
    finally:
        plt.close("all")
    return problems


@pytest.fixture(scope="module")
def file_runs(tmp_path_factory):
    runs: Dict[Path, FileRun] = {}

    def get(path: Path) -> FileRun:
        if path not in runs:
            runs[path] = FileRun(tmp_path_factory.mktemp(f"docs-{path.stem}"))
        return runs[path]

    return get


@pytest.mark.parametrize("block", BLOCKS, ids=[b.id for b in BLOCKS])
def test_doc_block(block, file_runs, monkeypatch):
    run = file_runs(block.path)
    # The earlier blocks of the file first, if this item runs alone (or they were deselected).
    for prev in python_blocks(block.path)[run.done:block.index - 1]:
        if not prev.skip:
            try:
                run_block(prev, run, monkeypatch)
            except Exception as exc:  # its own item reports it; this block may not need it
                print(f"(earlier block {prev.id} failed: {exc!r})")
        run.done = prev.index
    run.done = block.index
    if block.skip:
        pytest.skip(f"marked in the docs: {block.skip}")
    problems = run_block(block, run, monkeypatch)
    assert not problems, "printed output differs from the docs' '# ->' comments:\n" + "\n".join(problems)


def test_collector_finds_the_examples():
    """The collector sees the README's and the user guide's examples, and skip markers give reasons."""
    names = {b.path.name for b in BLOCKS}
    assert {"README.md", "user_guide.md"} <= names
    assert all(not b.path.is_relative_to(ROOT / "docs" / "notes") for b in BLOCKS)
    assert all(b.skip != "(no reason given)" for b in BLOCKS)
    assert sum(bool(expectations(b.source)) for b in BLOCKS) >= 5


@pytest.mark.parametrize("printed, expected, ok", [
    ("flutter 25.008910599826137 13.71903577908339", "flutter 25.0089106 13.719", True),
    ("flutter 25.0089115 13.719", "flutter 25.0089106 13.719", False),
    ("[ 3.51601828  3.75802322\n  7.40887212 13.2379489 ]", "[3.516 3.758 7.409 13.238]", True),
    ("[0.00000000e+00 3.20479199e-03]", "[0 3.2e-3]", True),
    ("[0.00000000e+00 3.26e-03]", "[0 3.2e-3]", False),
    ("stable [4.2448]", "divergence [4.245]", False),
    ("[1.0 2.0]", "[1.0 2.0 3.0]", False),
    ("-0.5340824 6.75", "-0.534 6.75", True),
])
def test_compare(printed, expected, ok):
    assert (compare(printed, expected) is None) == ok
