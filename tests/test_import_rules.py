"""docs/design.md's rules between folders, checked on every Python file of the tree.

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

#: (folder prefix, forbidden module prefixes, why[, exempt path prefixes]). Every rule whose
#: prefix matches the file's path applies (all are checked), except where the file is exempt.
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
    ("service/", ("impactnet.service.api",),
     "the layers run api -> codecs -> serving core -> models: nothing below the API imports it",
     ("service/api/", "service/app.py")),  # the API itself, and the module that assembles it
    ("models/bundle/", ("impactnet.models.learned", "impactnet.models.predictors"),
     "the bundle format reads and writes tensors and manifests; it knows no predictor"),
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
        for prefix, forbidden, why, *exempt in RULES:
            if relative.startswith(prefix) and not any(
                    relative.startswith(e) for e in (exempt[0] if exempt else ())):
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


#: Package of each folder of the tree, as installed.
PACKAGES = {"impactnet": "impactnet", "models": "impactnet.models",
            "service": "impactnet.service", "training": "impactnet.training",
            "scenes": "impactnet.scenes"}


def _module_names() -> dict[str, Path]:
    """Installed module name -> file, for every module of the package folders."""
    out = {}
    for folder, package in PACKAGES.items():
        for path in sorted((REPO / folder).rglob("*.py")):
            if "bundles" in path.relative_to(REPO).parts:
                continue
            parts = list(path.relative_to(REPO / folder).with_suffix("").parts)
            parts = parts[:-1] if parts[-1] == "__init__" else parts
            out[".".join([package, *parts])] = path
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of the tree it imports (at any depth, lazily or not; a package's
    import of its own submodules and a module's of its parents' ``__init__`` are not edges)."""
    modules = _module_names()
    graph = {}
    for name, path in modules.items():
        edges = set()
        for _, module in imported_modules(path):
            while module and module not in modules:  # `from a.b import name`: module a.b
                module = module.rpartition(".")[0]
            if module and module != name and not name.startswith(module + "."):
                edges.add(module)
        graph[name] = edges
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import loops of ``graph``: its strongly connected components of two or more
    modules (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            for target in edges:
                if target not in index:
                    index[target] = low[target] = counter
                    counter += 1
                    stack.append(target)
                    on_stack.add(target)
                    work.append((target, iter(sorted(graph[target]))))
                    break
                if target in on_stack:
                    low[node] = min(low[node], index[target])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def test_no_module_imports_itself_back_even_inside_a_function():
    assert not loops(import_graph()), "\n".join(" <-> ".join(c) for c in loops(import_graph()))


def test_the_loop_finder_finds_a_loop_through_a_lazy_import():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert loops(graph) == [["a", "b", "c"]]
    assert loops({"a": {"b"}, "b": set()}) == []
