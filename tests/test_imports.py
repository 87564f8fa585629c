"""Import directions: the isj vocabulary ← isj.fem, isj.lumped; isj.lumped ← isj.calibration;
isj.fem, isj.calibration ← isj.studies; everything ← isj.reports and the CLI.
gmsh is imported inside fem functions only.

The folders fem/, lumped/, calibration/ and reports/ sit beside isj/ in the
repository and install as isj.fem, isj.lumped, ...; the part a module belongs
to is its folder, and the part an import reaches is its second dotted name."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("isj", "fem", "lumped", "calibration", "reports")

# what each package may import from the project; isj's CLI is the one place in
# isj that may reach the model packages (the CLI sits on top of everything)
ALLOWED = {
    "isj": {"isj"},
    "fem": {"isj", "fem"},
    "lumped": {"isj", "lumped"},
    "calibration": {"isj", "lumped", "calibration"},
    "studies": {"isj", "fem", "lumped", "calibration", "studies"},
    "reports": set(PACKAGES) | {"studies"},
}
TOP_OF_STACK = {"isj/cli.py", "isj/provenance.py", "isj/__main__.py", "isj/__init__.py"}


def _is_top_of_stack(rel: str) -> bool:
    return rel in TOP_OF_STACK or rel.startswith(("isj/_cli/", "isj/app/"))  # the CLI and isj app


SUBPACKAGES = ("fem", "lumped", "calibration", "studies", "reports")


def _file_part(rel: str) -> str:
    """The project part a source file belongs to: its folder, or ``studies`` for isj/studies/."""
    return "studies" if rel.startswith("isj/studies/") else rel.split("/")[0]


def _part(dotted: str) -> str:
    """The project part an absolute import reaches: isj.fem.x -> fem, isj.design -> isj;
    anything outside the project keeps its own top-level name."""
    parts = dotted.split(".")
    if parts[0] != "isj":
        return parts[0]
    return parts[1] if len(parts) > 1 and parts[1] in SUBPACKAGES else "isj"


def project_imports(path: Path) -> list[tuple[str, bool]]:
    """(project part or outside package, at module level?) for each import in a file."""
    tree = ast.parse(path.read_text())
    module_level = {id(n) for n in tree.body}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: stays inside its own package
                continue
            mod = node.module or ""
            # `from isj import fem` reaches the subpackage, not the vocabulary
            names = [f"{mod}.{a.name}" if mod == "isj" else mod for a in node.names]
        else:
            continue
        for n in names:
            out.append((_part(n), id(node) in module_level))
    return out


def source_files():
    for pkg in PACKAGES:
        d = ROOT / pkg
        if d.is_dir():
            yield from sorted(d.rglob("*.py"))


def _module_name(rel: str) -> str:
    """fem/ear/shell -> isj.fem.ear.shell; isj/design -> isj.design."""
    dotted = rel.replace("/", ".")
    return dotted if dotted.startswith("isj") else f"isj.{dotted}"


def test_import_directions():
    bad = []
    for f in source_files():
        rel = f.relative_to(ROOT).as_posix()
        pkg = _file_part(rel)
        allowed = set(ALLOWED) if _is_top_of_stack(rel) else ALLOWED[pkg]
        for name, _ in project_imports(f):
            if name in ALLOWED and name not in allowed:
                bad.append(f"{rel} imports {name}")
    assert not bad, bad


def test_gmsh_only_inside_fem_functions():
    bad = []
    for f in source_files():
        rel = f.relative_to(ROOT).as_posix()
        for name, top in project_imports(f):
            if name == "gmsh" and (top or not rel.startswith("fem/")):
                bad.append(rel)
    assert not bad, bad


@pytest.mark.slow
def test_packages_import_without_gmsh():
    """With gmsh made unimportable, every package and module still imports."""
    mods = sorted(
        _module_name(f.relative_to(ROOT).with_suffix("").as_posix())
        for f in source_files()
        if f.name != "__main__.py"
    )
    code = (
        "import sys; sys.modules['gmsh'] = None\n"
        "import importlib\n"
        f"for m in {mods!r}: importlib.import_module(m.removesuffix('.__init__'))\n"
        "print('ok')\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ok"


@pytest.mark.parametrize(
    "pkg", ["isj", "isj.fem", "isj.lumped", "isj.calibration", "isj.studies", "isj.reports"]
)
def test_package_has_docstring(pkg):
    import importlib

    assert importlib.import_module(pkg).__doc__


NAMESPACE_PROBE = (
    "import importlib.util, sys\n"
    "assert importlib.util.find_spec('fem') is None, 'a top-level fem is importable'\n"
    "assert importlib.util.find_spec('lumped') is None, 'a top-level lumped is importable'\n"
    "import isj.fem, isj.lumped.artifact as a, isj.calibration, isj.reports\n"
    "a.default_calibration()\n"
    "print(isj.fem.__file__)\n"
)


def test_one_namespace_editable(tmp_path):
    """From a folder outside the repository only the isj namespace is there."""
    r = subprocess.run([sys.executable, "-c", NAMESPACE_PROBE], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert Path(r.stdout.strip()).resolve() == ROOT / "fem" / "__init__.py"


@pytest.mark.slow
def test_one_namespace_wheel(tmp_path):
    """A wheel built from the repository holds isj/fem, isj/lumped, ... and no top-level fem."""
    import zipfile

    wheels = tmp_path / "wheels"
    r = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(ROOT)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    (whl,) = wheels.glob("isj-*.whl")
    site = tmp_path / "site"
    with zipfile.ZipFile(whl) as z:
        names = z.namelist()
        z.extractall(site)
    tops = {n.split("/")[0] for n in names if not n.startswith("isj-")}
    assert tops == {"isj"}, tops
    assert "isj/lumped/data/default_calibration.json" in names
    env = {"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"}
    r = subprocess.run(
        [sys.executable, "-c", NAMESPACE_PROBE], capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert r.returncode == 0, r.stderr
    assert Path(r.stdout.strip()).resolve() == (site / "isj" / "fem" / "__init__.py").resolve()


def _module_of(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("").as_posix()
    return _module_name(rel).removesuffix(".__init__")


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of import nodes under ``if TYPE_CHECKING:``: they never run."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out |= {id(n) for b in node.body for n in ast.walk(b)}
    return out


def import_graph() -> dict[str, set[str]]:
    """Project module -> project modules it imports, at module level or inside functions.

    ``from P import name`` reaches the module ``P.name`` when that is a module, else ``P``.
    """
    files = {_module_of(f): f for f in source_files() if f.name != "__main__.py"}
    graph: dict[str, set[str]] = {}
    for mod, f in files.items():
        tree = ast.parse(f.read_text())
        skip = _type_checking_nodes(tree)
        package = mod if f.name == "__init__.py" else mod.rpartition(".")[0]
        targets = set()
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                targets |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")
                    anchor = anchor[: len(anchor) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    targets.add(sub if sub in files else base)
        graph[mod] = {t for t in targets if t in files and t != mod}
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def test_cycle_finder_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert import_cycles(graph) == [["a", "b", "c"]]
    assert import_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    """No two project modules import each other, directly or through others,
    counting imports inside functions: a lazy import hides a cycle, it does not remove it."""
    assert import_cycles(import_graph()) == []
