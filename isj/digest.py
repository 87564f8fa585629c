"""Which isj modules a piece of code reaches, found through the import system.

:func:`closure` gives some isj modules and every isj module they import, directly or
through others, at module level or inside functions (a lazy import inside a function is as
much a dependency as one at the top); :func:`function_imports` the modules that given
functions import. Modules are located through the import system
(:func:`importlib.util.find_spec`) and their source is read through their loader
(``get_source``), never by file path, so the answer is the same in a source checkout, an
editable install, a wheel or a zip.

No cache key hashes code: keys hold results versions (:mod:`isj.results_version`). This
module serves the tests that check that each report step's declared result families cover
the code it reaches (:func:`isj.reports.steps.step_modules`, tests/test_cache_keys.py) and
that no key function loads it.

Imports under ``if TYPE_CHECKING:`` are left out: they never run. Modules outside isj
(numpy, gmsh, ...) are left out too.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import inspect
import marshal
import textwrap
from collections.abc import Callable, Iterable, Mapping

#: Top-level package whose modules count as "own code".
PROJECT = __name__.partition(".")[0]


def _own(name: str) -> bool:
    return name == PROJECT or name.startswith(PROJECT + ".")


@functools.cache
def _spec(name: str):
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"no module named {name!r}", name=name)
    return spec


def _is_package(name: str) -> bool:
    return _spec(name).submodule_search_locations is not None


@functools.cache
def module_source(name: str) -> str:
    """Source text of the module ``name``, read through its loader.

    A module shipped without source (only bytecode) is represented by its
    marshalled code object instead, which still changes whenever the code does.
    """
    spec = _spec(name)
    source = spec.loader.get_source(name) if hasattr(spec.loader, "get_source") else None
    if source is None:
        return marshal.dumps(spec.loader.get_code(name)).hex()
    return source


def _type_checking_block(node: ast.AST) -> bool:
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and (
        (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
        or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")
    )


def _import_nodes(tree: ast.AST):
    """Import statements anywhere in ``tree`` except under ``if TYPE_CHECKING:``."""
    todo = [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        for child in ast.iter_child_nodes(node):
            if not _type_checking_block(child):
                todo.append(child)


def imports_in(tree: ast.AST, package: str) -> frozenset[str]:
    """isj modules that the import statements in ``tree`` load.

    Parameters
    ----------
    tree : a parsed module or function
    package : the package relative imports are resolved against (``"isj.fem"`` for
        a module of ``isj.fem``)

    Returns
    -------
    frozenset of str
        ``from isj.design import Geometry`` gives ``isj.design``; ``from isj import fem``
        gives ``isj.fem`` (a submodule), ``from isj import __version__`` gives ``isj``.
    """
    found: set[str] = set()
    for node in _import_nodes(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if _own(a.name))
            continue
        base = importlib.util.resolve_name("." * node.level + (node.module or ""), package)
        if not _own(base):
            continue
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            # `from pkg import name`: a submodule if pkg has one by that name, else an attribute of pkg
            found.add(sub if _is_package(base) and importlib.util.find_spec(sub) is not None else base)
    return frozenset(found)


@functools.cache
def module_imports(name: str) -> frozenset[str]:
    """isj modules that the module ``name`` imports, anywhere in it."""
    return imports_in(ast.parse(module_source(name)), _package_of(name))


def _package_of(name: str) -> str:
    return name if _is_package(name) else name.rpartition(".")[0]


def top_level_names(name: str) -> dict[str, str]:
    """Names that the top-level imports of the module ``name`` bind → the isj module each comes from.

    ``from isj.cases import THESIS_CASES`` gives ``{"THESIS_CASES": "isj.cases"}``;
    ``from isj import fem`` gives ``{"fem": "isj.fem"}``. Imports from outside isj are left out.
    """
    return dict(_top_level_names(name))  # a copy: the cached one stays as read


@functools.cache
def _top_level_names(name: str) -> dict[str, str]:
    package = _package_of(name)
    out: dict[str, str] = {}
    for node in ast.parse(module_source(name)).body:
        if isinstance(node, ast.Import):
            for a in node.names:
                if _own(a.name):
                    out[a.asname or a.name.partition(".")[0]] = a.name
        elif isinstance(node, ast.ImportFrom):
            for a in node.names:
                tree = ast.Module(body=[ast.ImportFrom(node.module, [a], node.level)], type_ignores=[])
                for module in imports_in(tree, package):
                    out[a.asname or a.name] = module
    return out


def closure(modules: Iterable[str]) -> tuple[str, ...]:
    """The isj modules among ``modules`` and every isj module they import, transitively; sorted."""
    seen: set[str] = set()
    todo = [m for m in modules if _own(m)]
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo.extend(module_imports(name) - seen)
    return tuple(sorted(seen))


def function_imports(
    *functions: Callable, follow: Mapping[str, Callable | str] | None = None
) -> frozenset[str]:
    """isj modules that ``functions`` import inside their bodies, following the names in ``follow``.

    A function that mentions a key of ``follow`` (as a name, ``helper(...)``, or as an
    attribute, ``ctx.helper``) brings in what that value reaches too: a function's own
    imports (and, in turn, the names it mentions), or a module name as given.

    Parameters
    ----------
    functions : functions or properties whose source can be read (``inspect.getsource``)
    follow : name → function, property or module name

    Returns
    -------
    frozenset of str
        Module names; pass them to :func:`closure` for their closure.
    """
    follow = dict(follow or {})
    found: set[str] = set()
    seen: set[int] = set()
    todo: list = list(functions)
    while todo:
        fn = todo.pop()
        if isinstance(fn, str):
            found.add(fn)
            continue
        fn = fn.fget if isinstance(fn, property) else fn
        if id(fn) in seen:
            continue
        seen.add(id(fn))
        tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
        found |= imports_in(tree, fn.__module__.rpartition(".")[0])
        for node in ast.walk(tree):
            word = node.id if isinstance(node, ast.Name) else getattr(node, "attr", None)
            if isinstance(word, str) and word in follow:
                todo.append(follow[word])
    return frozenset(found)
