"""DESIGN.md's rules between folders, checked on every Python file of the tree.

Every ``import`` and ``from ... import`` statement (at any depth: a lazy import inside a function
counts too) of every file under ``impactnet/``, ``models/``, ``service/``, ``training/``,
``scenes/`` and ``tests/`` is read with :mod:`ast`, and the imported module is checked against the
rules of the folder the file lives in. No list of file names: a new file is checked as soon as it
exists.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CHECKED = ("impactnet", "models", "service", "training", "scenes", "tests")
#: The flat names of the repository folders: code imports them only as ``impactnet.<name>``.
FLAT_NAMES = ("models", "service", "training", "scenes")

#: (folder prefix, forbidden module prefixes, why). The first rule whose prefix matches the
#: file's folder applies with every later matching rule too (all are checked).
RULES = [
    ("models/", ("impactnet.training", "impactnet.service", "torch", "fastapi", "starlette",
                 "uvicorn", "mujoco"),
     "models/ imports neither training/ nor service/, nor torch, fastapi or mujoco"),
    ("models/geometry/", ("impactnet.models.box", "impactnet.models.learned",
                          "impactnet.models.bundle"),
     "geometry is shared by every solver and depends on none"),
    ("models/box/", ("impactnet.models.learned", "impactnet.models.bundle"),
     "the exact solver never depends on the learned predictors"),
    ("models/bundle/", ("impactnet.models.box",),
     "a bundle holds learned models; the exact solver is not its business"),
    ("service/", ("torch", "impactnet.training", "mujoco"),
     "service/ never imports torch, nor the training stack"),
    ("training/", ("fastapi", "starlette", "impactnet.service.api"),
     "training/ never imports fastapi"),
    ("tests/models/", ("impactnet.training", "impactnet.service", "tests.training",
                       "tests.service"),
     "the models' tests stand on the models alone"),
]


def _python_files():
    for folder in CHECKED:
        for path in sorted((REPO / folder).rglob("*.py")):
            if "bundles" not in path.relative_to(REPO).parts:
                yield path


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of every absolute import in ``path``; ``from a import b`` gives
    ``a.b`` (b may be a submodule), relative imports are resolved against the file's package."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: the package of the file, `level` up
                parts = list(path.relative_to(REPO).parent.parts)
                base = ".".join(parts[: len(parts) - (node.level - 1)])
                module = ".".join(p for p in (base, node.module) if p)
            else:
                module = node.module or ""
            found += [(node.lineno, f"{module}.{alias.name}") for alias in node.names]
    return found


def _violations(path: Path) -> list[str]:
    relative = path.relative_to(REPO).as_posix()
    out = []
    for line, module in imported_modules(path):
        root = module.split(".")[0]
        if root in FLAT_NAMES:
            out.append(f"{relative}:{line}: {module} (import it as impactnet.{module})")
        for prefix, forbidden, why in RULES:
            if relative.startswith(prefix):
                for bad in forbidden:
                    if module == bad or module.startswith(bad + "."):
                        out.append(f"{relative}:{line}: {module} ({why})")
    return out


def test_every_file_keeps_the_rules_between_folders():
    files = list(_python_files())
    assert len(files) > 200  # the walk found the tree
    problems = [v for path in files for v in _violations(path)]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("source,expected", [
    ("import torch\n", ["models/x.py:1: torch"]),
    ("def f():\n    from impactnet.training.bench import runner\n",
     ["models/x.py:2: impactnet.training.bench.runner"]),
    ("from models.box import exact\n", ["models/x.py:1: models.box.exact"]),
    ("from impactnet.models.box import exact\n", []),
])
def test_a_forbidden_import_is_found_even_inside_a_function(tmp_path, source, expected):
    """The checker itself: a lazy import counts, a flat name is refused."""
    (tmp_path / "models").mkdir()
    path = tmp_path / "models" / "x.py"
    path.write_text(source, encoding="utf-8")
    found = [v.split(" (")[0] for v in _violations_at(path, tmp_path)]
    assert found == expected


def _violations_at(path: Path, repo: Path) -> list[str]:
    global REPO
    saved, REPO = REPO, repo
    try:
        return _violations(path)
    finally:
        REPO = saved
