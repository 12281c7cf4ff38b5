"""Docs that are true (issue #33, item 6): every figure names the command that made it, the cheap
ones are made again and must agree, and the README's examples print what the README shows.

Conventions: tests/docs/markdown.py.
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import pytest

from tests.docs.markdown import (
    REPO,
    examples,
    figures,
    generated_command,
    markdown_files,
    numbers,
)
from tests.service.conftest import ServerProcess

#: Seconds a rerun command or an example may take.
RUN_TIMEOUT_S = 300
#: Where the docs' examples say the service runs.
DOC_ADDRESS = re.compile(r"(localhost|127\.0\.0\.1):8000")


def _unsourced() -> list[str]:
    out = []
    for path in markdown_files():
        if generated_command(path) is not None:
            continue
        out += [f"{f.path.relative_to(REPO)}:{f.line}: {f.text.splitlines()[0][:70]}"
                for f in figures(path) if f.source is None]
    return out


def test_every_figure_names_the_command_that_made_it():
    missing = _unsourced()
    assert not missing, "figures without a source marker:\n" + "\n".join(missing)


def _reruns():
    return [f for path in markdown_files() for f in figures(path) if f.rerun]


def _agrees(shown: str, output: str) -> list[str]:
    """The numbers of ``shown`` that ``output`` does not hold (within their shown digits)."""
    got = [value for value, _ in numbers(output)]
    return [f"{value:g}" for value, resolution in numbers(shown)
            if not any(abs(value - g) <= resolution * (1 + 1e-9) for g in got)]


def _run(command: str, env: dict | None = None) -> str:
    cmd = shlex.split(command)
    if cmd[0] == "impactnet":
        cmd = [sys.executable, "-m", "impactnet.cli", *cmd[1:]]
    result = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True,
                            timeout=RUN_TIMEOUT_S, env={**os.environ, **(env or {})})
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


@pytest.mark.parametrize("figure", _reruns(), ids=lambda f: f"{f.path.name}:{f.line}")
def test_a_cheap_figure_is_made_again_the_same(figure):
    table = "\n".join(line for line in figure.text.splitlines() if not line.startswith("|--"))
    header = table.splitlines()[0] if table.startswith("|") else ""
    body = table[len(header):]
    assert not _agrees(body, _run(figure.source))


@pytest.fixture(scope="module")
def docs_server():
    proc = ServerProcess(args=["--no-access-log"], bundle_default=True)
    try:
        proc.wait_ready(timeout=120)
        yield proc
    finally:
        proc.cleanup()


def _readme_examples():
    return examples(REPO / "README.md")


@pytest.mark.parametrize("example", _readme_examples(), ids=lambda e: f"README:{e.line}")
def test_a_readme_example_prints_what_the_readme_shows(example, docs_server):
    code = DOC_ADDRESS.sub(f"127.0.0.1:{docs_server.port}", example.code)
    if example.language == "python":
        result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                                text=True, timeout=RUN_TIMEOUT_S)
    else:
        result = subprocess.run(["bash", "-c", code], cwd=REPO, capture_output=True, text=True,
                                timeout=RUN_TIMEOUT_S)
    assert result.returncode == 0, result.stderr[-2000:]
    missing = _agrees(example.output, result.stdout)
    assert not missing, f"shown but not printed: {missing}\nprinted:\n{result.stdout[:2000]}"
