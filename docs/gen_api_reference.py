"""mkdocs hook: the Python API reference, generated from the docstrings with mkdocstrings.

Three things happen at build time (``hooks:`` in ``mkdocs.yml``):

- :func:`on_config` copies the sources into ``build/docs-api/`` in the layout an install has.
  In the repository the subpackages sit beside ``isj/`` (``fem/`` is ``isj.fem``, ``lumped/`` is
  ``isj.lumped``, ...: ``[tool.setuptools.package-dir]`` in ``pyproject.toml``), so a static
  reader of the source (griffe, behind mkdocstrings) finds ``isj`` but not ``isj.fem``; the
  Python handler's ``paths`` in ``mkdocs.yml`` points at the copy. (Copies, not links: griffe
  resolves a link to its real folder.)
- :func:`on_files` adds one page per package, ``reference/modules/<package>.md``, with a
  ``:::`` block for each of its public modules (no leading underscore), found by walking the
  copy, so a module that is added, moved or renamed appears without editing the docs.
- :func:`on_page_markdown` replaces the marker ``<!-- public-names -->`` in
  ``reference/api.md`` with tables of the public names (``isj.__all__`` and each package's
  ``__all__``), each linked to where it is documented, and ``<!-- model-vocabulary -->`` with
  the table of the model classes and their ``static``, ``frequency_response`` and
  ``natural_frequencies_hz`` methods.
"""

from __future__ import annotations

import ast
import shutil
import tomllib
from pathlib import Path

from mkdocs.plugins import event_priority

ROOT = Path(__file__).resolve().parent.parent
#: Where the installed layout is made (``build/`` is ignored by git).
STAGE = ROOT / "build" / "docs-api"
#: Packages that get a page of their modules, in the order of the layering (docs/developer/index.md).
PACKAGES = (
    "isj",
    "isj.fem",
    "isj.fem.ear",
    "isj.fem.rom",
    "isj.lumped",
    "isj.calibration",
    "isj.studies",
    "isj.reports",
)
MARKER = "<!-- public-names -->"


def package_dirs() -> dict[str, Path]:
    """Dotted package name → source folder, from ``[tool.setuptools.package-dir]``."""
    with open(ROOT / "pyproject.toml", "rb") as f:
        mapping = tomllib.load(f)["tool"]["setuptools"]["package-dir"]
    return {name: ROOT / folder for name, folder in mapping.items()}


def stage() -> Path:
    """Copy the sources into ``STAGE`` in the installed layout; returns ``STAGE``."""
    if STAGE.exists():
        shutil.rmtree(STAGE)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    # parents first: isj/, then isj/fem/; isj/fem/ear/ is already inside fem/
    for name, folder in sorted(package_dirs().items(), key=lambda item: item[0].count(".")):
        target = STAGE.joinpath(*name.split("."))
        if not target.exists():
            shutil.copytree(folder, target, ignore=ignore)
    return STAGE


def _folder(package: str) -> Path:
    return STAGE.joinpath(*package.split("."))


def public_modules(package: str) -> list[str]:
    """Dotted names of the public modules of ``package``: its own, and those of its subpackages
    that have no page of their own (not in :data:`PACKAGES`), each subpackage before its modules."""
    out = []
    for path in sorted(_folder(package).glob("*.py")):
        if path.stem.startswith("_"):
            continue
        out.append(f"{package}.{path.stem}")
    for path in sorted(_folder(package).iterdir()):
        sub = f"{package}.{path.name}"
        if path.is_dir() and (path / "__init__.py").exists() and not path.name.startswith("_"):
            if sub not in PACKAGES:
                out += [sub, *public_modules(sub)]
    return out


def module_page(package: str) -> str:
    """Markdown of the page that documents every public module of ``package``."""
    lines = [f"# `{package}`", ""]
    if package != "isj":  # `isj` itself is on reference/api.md
        local = _local_names(package)
        members = f"[{', '.join(local)}]" if local else "false"
        lines += [f"::: {package}", "    options:", f"      members: {members}", ""]
    for module in public_modules(package):
        lines += [f"::: {module}", ""]
    return "\n".join(lines)


def page_path(package: str) -> str:
    return f"reference/modules/{package}.md"


def _all_names(package: str) -> list[tuple[str, str]]:
    """(name, dotted path where it is defined) for each name in ``package.__all__``."""
    source = (_folder(package) / "__init__.py").read_text(encoding="utf-8")
    tree = ast.parse(source)
    names: list[str] = []
    lazy: dict[str, str] = {}
    imported: dict[str, str] = {}
    for node in tree.body:
        target = node.targets[0] if isinstance(node, ast.Assign) else getattr(node, "target", None)
        if isinstance(node, ast.Assign | ast.AnnAssign) and isinstance(target, ast.Name):
            if target.id == "_LAZY" and isinstance(node.value, ast.Dict):
                lazy = {
                    ast.literal_eval(k): ast.literal_eval(v)
                    for k, v in zip(node.value.keys, node.value.values, strict=True)
                }
            if target.id == "__all__" and isinstance(node.value, ast.List):
                for elt in node.value.elts:
                    if isinstance(elt, ast.Constant):
                        names.append(elt.value)
                    elif isinstance(elt, ast.Starred):  # isj: ["__version__", *sorted(_LAZY)]
                        names.extend(sorted(lazy))
        if isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
            mod = ".".join([*base, node.module] if node.module else base)
            for alias in node.names:
                imported[alias.asname or alias.name] = f"{mod}.{alias.name}"
    out = []
    for name in names:
        if name.startswith("__"):
            continue
        where = f"{lazy[name]}.{name}" if name in lazy else imported.get(name, f"{package}.{name}")
        out.append((name, where))
    return out


def _local_names(package: str) -> list[str]:
    """Names of ``package.__all__`` that its ``__init__.py`` defines itself (not imports)."""
    tree = ast.parse((_folder(package) / "__init__.py").read_text(encoding="utf-8"))
    defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef | ast.ClassDef)}
    return [name for name, where in _all_names(package) if name in defined and where == f"{package}.{name}"]


def _documented(module: str, name: str) -> bool:
    """Whether ``module`` defines ``name`` itself (a class, function or value, not ``X = Y``)."""
    parts = module.split(".")
    path = STAGE.joinpath(*parts).with_suffix(".py")
    if not path.exists():
        path = STAGE.joinpath(*parts, "__init__.py")
    if not path.exists():
        return False
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ClassDef | ast.FunctionDef) and node.name == name:
            return True
        if isinstance(node, ast.Assign | ast.AnnAssign) and not isinstance(node.value, ast.Name | None):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                return True
    return False


def _page_of(dotted: str) -> str | None:
    """The generated page that documents ``dotted`` (a module's member), if any."""
    module, name = dotted.rsplit(".", 1)
    if not _documented(module, name):
        return None
    if module in PACKAGES and module != "isj":
        return page_path(module)
    for package in sorted(PACKAGES, key=len, reverse=True):
        if module in public_modules(package):
            return page_path(package)
    return None


def public_names_markdown() -> str:
    """Tables of the public names of each package, linked to their documentation."""
    lines = []
    for package in PACKAGES:
        if not (_folder(package) / "__init__.py").exists():
            continue
        rows = _all_names(package)
        if not rows:
            continue
        lines += [f"### `{package}`", "", "| name | defined in |", "|---|---|"]
        for name, where in rows:
            link = f"[`{where}`][{where}]" if _page_of(where) else f"`{where}`"  # mkdocs-autorefs
            lines.append(f"| `{name}` | {link} |")
        lines.append("")
    return "\n".join(lines)


#: The methods every model answers to (issue 23: one vocabulary).
VOCABULARY = ("static", "frequency_response", "natural_frequencies_hz")
VOCABULARY_MARKER = "<!-- model-vocabulary -->"


def _module_file(module: str) -> Path:
    parts = module.split(".")
    path = STAGE.joinpath(*parts).with_suffix(".py")
    return path if path.exists() else STAGE.joinpath(*parts, "__init__.py")


def model_classes() -> list[tuple[str, set[str]]]:
    """(dotted class, the methods of :data:`VOCABULARY` it defines) for every public class with any."""
    out = []
    for package in PACKAGES:
        for module in [package, *public_modules(package)]:
            path = _module_file(module)
            if not path.exists() or path.parent.name.startswith("_"):
                continue
            for node in ast.parse(path.read_text(encoding="utf-8")).body:
                if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                    methods = {
                        n.name for n in node.body if isinstance(n, ast.FunctionDef) and n.name in VOCABULARY
                    }
                    if methods:
                        out.append((f"{module}.{node.name}", methods))
    return sorted(set((c, frozenset(m)) for c, m in out), key=lambda item: item[0])


def vocabulary_markdown() -> str:
    """A table: each model class and which of the three methods it has, linked to their docs."""
    head = "| model | " + " | ".join(f"`{m}`" for m in VOCABULARY) + " |"
    lines = [head, "|---|" + "---|" * len(VOCABULARY)]
    for cls, methods in model_classes():
        cells = [f"[`{m}`][{cls}.{m}]" if m in methods else "—" for m in VOCABULARY]
        lines.append(f"| [`{cls.rsplit('.', 1)[1]}`][{cls}] | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


# before every plugin (default priority 0): mkdocstrings resolves its ``paths`` in its own
# on_config, and a folder that does not exist yet (a fresh clone) is left out
@event_priority(100)
def on_config(config):
    """mkdocs hook: stage the package before mkdocstrings reads it."""
    stage()
    return config


def on_files(files, config):
    """mkdocs hook: add the generated module pages."""
    from mkdocs.structure.files import File

    for package in PACKAGES:
        if _folder(package).exists():
            files.append(File.generated(config, page_path(package), content=module_page(package)))
    return files


def on_page_markdown(markdown, page, config, files):
    """mkdocs hook: fill the public-names marker of ``reference/api.md``."""
    if page.file.src_uri == "reference/api.md":
        markdown = markdown.replace(MARKER, public_names_markdown())
        markdown = markdown.replace(VOCABULARY_MARKER, vocabulary_markdown())
    return markdown
