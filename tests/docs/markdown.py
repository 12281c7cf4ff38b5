"""Reading the project's Markdown for the docs tests: figure blocks and their sources, and the
examples with the output they show.

Conventions the docs follow (checked by tests/docs/test_figures.py and test_examples.py):

* a **figure** is a Markdown table that holds a number, or an image; it names the command that
  made it in an HTML comment at most :data:`SOURCE_LINES` lines above it:
  ``<!-- figures: impactnet bench hostile --out docs/benchmarks -->``; a table of settings,
  limits or definitions (no measurement) says ``<!-- figures: reference -->``; a report that a
  command writes whole (docs/benchmarks/*.md, docs/evaluation/**/*.md) names its command in its
  first :data:`HEADER_LINES` lines instead, and that covers every figure in it;
* a **cheap** figure's marker says ``rerun``: ``<!-- figures (rerun): impactnet contact -->``;
  the test runs the command and every number of the block must be in its output;
* an **example** is a ```python or ```bash (curl) block followed by a ```text or ```json block:
  the output the example prints, compared number by number to the digits shown.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: Lines above a figure within which its source marker must be.
SOURCE_LINES = 8
#: Lines at the top of a generated report within which its command must be named.
HEADER_LINES = 8
#: A figure's source marker: ``<!-- figures: COMMAND -->`` or ``<!-- figures (rerun): ... -->``.
MARKER = re.compile(r"<!--\s*figures(\s*\(rerun\))?:\s*(.+?)\s*-->")
#: A number as shown in the docs: digits with thousands commas, a decimal part, an exponent.
NUMBER = re.compile(r"(?<![\w.])[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?")
#: A command named in a generated report's header.
COMMAND = re.compile(r"`((?:\.venv/bin/)?(?:impactnet|python -m impactnet)[^`]*)`")
#: Folders whose Markdown files are reports written whole by a command.
GENERATED = ("docs/benchmarks", "docs/evaluation", "docs/paper_reproduction")


@dataclass(frozen=True)
class Figure:
    """A table or an image of a Markdown file."""

    path: Path
    line: int  # 1-based line of its first row
    text: str  # the block
    source: str | None  # the marker's command, "reference", or None
    rerun: bool  # the marker asks for a rerun


@dataclass(frozen=True)
class Example:
    """A code block and the output block that follows it."""

    path: Path
    line: int
    language: str  # python or bash
    code: str
    output: str
    output_language: str  # text or json


def markdown_files() -> list[Path]:
    """README.md and every Markdown file under docs/."""
    return [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]


def generated_command(path: Path) -> str | None:
    """The command a generated report names in its header, or None."""
    relative = path.relative_to(REPO).as_posix()
    if not relative.startswith(GENERATED):
        return None
    head = "\n".join(path.read_text(encoding="utf-8").splitlines()[:HEADER_LINES])
    found = COMMAND.search(head)
    return found.group(1) if found else None


def _marker_above(lines: list[str], start: int) -> tuple[str | None, bool]:
    for k in range(start - 1, max(-1, start - 1 - SOURCE_LINES), -1):
        found = MARKER.search(lines[k])
        if found:
            return found.group(2), bool(found.group(1))
        if lines[k].startswith("|") or lines[k].startswith("!["):
            break  # another figure's block: its marker is not this one's
    return None, False


def _blocks(lines: list[str]):
    """(start, text) of every table and image outside code blocks."""
    fenced, k = False, 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and line.startswith("|"):
            end = k
            while end < len(lines) and lines[end].startswith("|"):
                end += 1
            yield k, "\n".join(lines[k:end])
            k = end
            continue
        elif not fenced and "![" in line:
            yield k, line
        k += 1


def figures(path: Path) -> list[Figure]:
    """Every table holding a number, and every image, of ``path``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out = []
    for start, text in _blocks(lines):
        if text.startswith("|") and not NUMBER.search(text.replace("|---", "")):
            continue
        source, rerun = _marker_above(lines, start)
        out.append(Figure(path, start + 1, text, source, rerun))
    return out


def examples(path: Path) -> list[Example]:
    """Every ```python or ```bash block directly followed by a ```text or ```json block."""
    text = path.read_text(encoding="utf-8")
    pattern = re.compile(r"```(python|bash)\n(.*?)```\s*\n```(text|json)\n(.*?)```", re.S)
    return [Example(path, text[:m.start()].count("\n") + 1, m.group(1), m.group(2),
                    m.group(4), m.group(3)) for m in pattern.finditer(text)]


def numbers(text: str) -> list[tuple[float, float]]:
    """Every number of ``text`` with its resolution (half a unit of its last digit)."""
    out = []
    for match in NUMBER.finditer(text):
        shown = match.group(0).replace(",", "")
        mantissa = shown.split("e")[0]
        decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
        exponent = int(shown.split("e")[1]) if "e" in shown else 0
        out.append((float(shown), 0.5 * 10.0 ** (exponent - decimals)))
    return out
