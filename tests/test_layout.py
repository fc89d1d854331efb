"""The layout rules of docs/architecture.md: what each package may import, module size."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "coopproc"
SHARED = ("model", "names", "memory", "sensors", "errors", "frames", "timeconv", "configtools")

#: package -> coopproc packages/modules it must not import
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "io": ("stages", "run", "report", "cli", "sim", "checks"),
    "checks": ("stages", "run", "report", "cli", "sim"),
    "stages": ("io", "run", "report", "cli", "sim", "checks"),
    "report": ("io", "run", "cli", "sim", "checks", "stages.ranging", "stages.fusion"),
    "sim": ("stages", "run", "report", "checks", "cli"),
    "ins": ("io", "run", "report", "cli", "sim", "checks"),
    "gnss": ("stages", "run", "report", "cli", "sim", "checks"),
    "run": ("cli",),
}

#: "under ~400 lines" (ARCHITECTURE, issue 18)
MAX_LINES = 420


def _modules() -> list[Path]:
    return sorted(ROOT.rglob("*.py"))


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {n.removeprefix("coopproc.") for n in names if n.startswith("coopproc.")}


def _package(path: Path) -> str:
    rel = path.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_follow_the_layers(path: Path) -> None:
    package = _package(path)
    imported = _imports(path)
    if package in SHARED:
        others = {i for i in imported if i.split(".")[0] not in SHARED}
        assert not others, f"shared module {path.name} imports {sorted(others)}"
    for banned in FORBIDDEN.get(package, ()):
        bad = sorted(i for i in imported if i == banned or i.startswith(banned + "."))
        assert not bad, f"{path.relative_to(ROOT)} ({package}) must not import {bad}"


def test_modules_are_small() -> None:
    sizes = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in _modules()}
    big = {str(p.relative_to(ROOT)): n for p, n in sizes.items() if n > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


def test_cli_holds_no_algorithms() -> None:
    """The CLI calls the library: no numpy in a command module."""
    for path in (ROOT / "cli").glob("*.py"):
        assert "numpy" not in {i.split(".")[0] for i in _raw_imports(path)}, path.name


def _raw_imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names
