"""The import arrows (docs/architecture.md): app → analysis → drivers, no Qt below app/, no import cycle.

Every import of every module under analysis/, drivers/ and app/ counts, also those inside functions and under
``TYPE_CHECKING``; each failure names the file, the line and the import.
"""

from __future__ import annotations

import ast
import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("analysis", "drivers", "app")  # installed as gasfilm.<folder>
QT_PACKAGES = ("PySide6", "PySide2", "PyQt6", "PyQt5", "shiboken6", "shiboken2", "qtpy", "pyqtgraph")


@dataclass(frozen=True)
class Import:
    """One import statement's target, resolved to a full module name."""

    path: str  # the importing file, relative to the repository
    line: int
    importer: str
    target: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line} imports {self.target}"


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["gasfilm", *parts])


def project_imports(root: Path) -> tuple[frozenset[str], tuple[Import, ...]]:
    """The project's modules and every import in them; ``from package import name`` counts as importing the module
    ``package.name`` when that is one of the project's modules."""
    paths = {module_name(root, path): path for folder in FOLDERS for path in sorted((root / folder).rglob("*.py"))}
    imports = []
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(anchor + ([base] if base else []))
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in paths else base for alias in node.names]
            else:
                continue
            relative = path.relative_to(root).as_posix()
            imports += [Import(relative, node.lineno, name, target) for target in dict.fromkeys(targets)]
    return frozenset(paths), tuple(imports)


@functools.cache
def _repository_imports() -> tuple[frozenset[str], tuple[Import, ...]]:
    return project_imports(ROOT)


def _within(module: str, *packages: str) -> bool:
    return any(module == package or module.startswith(package + ".") for package in packages)


def drivers_violations(imports: tuple[Import, ...]) -> list[str]:
    """drivers/ imports nothing from analysis/ or app/ (under either name)."""
    return [
        f"{item}: drivers/ must not import analysis/ or app/"
        for item in imports
        if _within(item.importer, "gasfilm.drivers")
        and _within(item.target, "gasfilm.analysis", "gasfilm.app", "analysis", "app")
    ]


def analysis_violations(imports: tuple[Import, ...]) -> list[str]:
    """analysis/ imports neither app/ nor any Qt binding, pyqtgraph or matplotlib's Qt backends."""
    return [
        f"{item}: analysis/ must not import app/ or Qt"
        for item in imports
        if _within(item.importer, "gasfilm.analysis")
        and (
            _within(item.target, "gasfilm.app", "app", *QT_PACKAGES)
            or _within(item.target, "matplotlib.backends")
            and item.target.rpartition(".")[2].startswith("backend_qt")
        )
    ]


def import_cycles(modules: frozenset[str], imports: tuple[Import, ...]) -> list[str]:
    """One message per set of modules that import each other (a strongly connected component of the module graph),
    listing the modules and the imports that close the cycle."""
    names = sorted(modules)
    index = {name: position for position, name in enumerate(names)}
    edges = [item for item in imports if item.target in index and item.target != item.importer]
    graph = scipy.sparse.coo_matrix(
        (np.ones(len(edges)), ([index[e.importer] for e in edges], [index[e.target] for e in edges])),
        shape=(len(names), len(names)),
    )
    _, component = connected_components(graph, directed=True, connection="strong")
    messages = []
    for label in np.unique(component):
        members = [names[position] for position in np.flatnonzero(component == label)]
        if len(members) > 1:
            closing = [str(e) for e in edges if component[index[e.importer]] == component[index[e.target]] == label]
            messages.append(f"import cycle between {', '.join(members)}: {'; '.join(closing)}")
    return messages


def test_drivers_import_nothing_from_analysis_or_app():
    violations = drivers_violations(_repository_imports()[1])
    assert not violations, "\n".join(violations)


def test_analysis_imports_neither_app_nor_qt():
    violations = analysis_violations(_repository_imports()[1])
    assert not violations, "\n".join(violations)


def test_no_import_cycle_between_modules():
    cycles = import_cycles(*_repository_imports())
    assert not cycles, "\n".join(cycles)


def test_the_walk_sees_every_folder_and_resolves_imports_to_modules():
    modules, imports = _repository_imports()
    assert {module.split(".")[1] for module in modules} == set(FOLDERS)
    edges = {(item.importer, item.target) for item in imports}
    assert ("gasfilm.drivers.simulated", "gasfilm.drivers.plant") in edges
    assert ("gasfilm.analysis.physics.plant", "gasfilm.analysis.physics.response") in edges  # from package import module


def test_a_wrong_arrow_a_qt_import_and_a_cycle_are_reported_by_file_and_line(tmp_path):
    files = {
        "drivers/__init__.py": "",
        "drivers/device.py": "import numpy\nfrom gasfilm.analysis import a\n",
        "analysis/__init__.py": "",
        "analysis/a.py": "from . import b\nfrom PySide6.QtCore import QObject\n",
        "analysis/b.py": "def late():\n    from gasfilm.analysis.a import QObject\n",
        "analysis/plots.py": "from matplotlib.backends.backend_qtagg import FigureCanvas\nimport gasfilm.app.cli\n",
        "app/__init__.py": "",
        "app/cli.py": "from gasfilm.analysis import plots\nfrom gasfilm.drivers import device\n",
    }
    for relative, text in files.items():
        (tmp_path / relative).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / relative).write_text(text, encoding="utf-8")
    modules, imports = project_imports(tmp_path)
    assert drivers_violations(imports) == [
        "drivers/device.py:2 imports gasfilm.analysis.a: drivers/ must not import analysis/ or app/"
    ]
    assert analysis_violations(imports) == [
        "analysis/a.py:2 imports PySide6.QtCore: analysis/ must not import app/ or Qt",
        "analysis/plots.py:1 imports matplotlib.backends.backend_qtagg: analysis/ must not import app/ or Qt",
        "analysis/plots.py:2 imports gasfilm.app.cli: analysis/ must not import app/ or Qt",
    ]
    assert sorted(import_cycles(modules, imports)) == [
        "import cycle between gasfilm.analysis.a, gasfilm.analysis.b: analysis/a.py:1 imports gasfilm.analysis.b; "
        "analysis/b.py:2 imports gasfilm.analysis.a",
        "import cycle between gasfilm.analysis.plots, gasfilm.app.cli: analysis/plots.py:2 imports gasfilm.app.cli; "
        "app/cli.py:1 imports gasfilm.analysis.plots",
    ]
