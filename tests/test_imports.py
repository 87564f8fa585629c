"""Import directions (DEVELOPERS.md): isj vocabulary ← fem, lumped; lumped ← calibration;
everything ← reports and the CLI. And gmsh is imported inside fem functions only."""

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
    "reports": set(PACKAGES),
}
TOP_OF_STACK = {"isj/cli.py", "isj/provenance.py", "isj/__main__.py"}


def project_imports(path: Path) -> list[tuple[str, bool]]:
    """(top-level project package, at module level?) for each import in a file."""
    tree = ast.parse(path.read_text())
    module_level = {id(n) for n in tree.body}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: stays inside its own package
                continue
            names = [node.module or ""]
        else:
            continue
        for n in names:
            out.append((n.split(".")[0], id(node) in module_level))
    return out


def source_files():
    for pkg in PACKAGES:
        d = ROOT / pkg
        if d.is_dir():
            yield from sorted(d.rglob("*.py"))


def test_import_directions():
    bad = []
    for f in source_files():
        rel = f.relative_to(ROOT).as_posix()
        pkg = rel.split("/")[0]
        allowed = set(PACKAGES) if rel in TOP_OF_STACK else ALLOWED[pkg]
        for name, _ in project_imports(f):
            if name in PACKAGES and name not in allowed:
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


def test_packages_import_without_gmsh():
    """With gmsh made unimportable, every package and module still imports."""
    mods = sorted(
        f.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
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


@pytest.mark.parametrize("pkg", ["isj", "fem"])
def test_package_has_docstring(pkg):
    import importlib

    assert importlib.import_module(pkg).__doc__
