"""The manual (mkdocs.yml, docs/): its snippets run, its generated references are complete, its
citations resolve.

- the tutorial's Python session (docs/examples/first_session.py) runs as a user runs it, and
  its numbers obey the physics: a softer gap turns the joint more (α up), the FE check of the
  same design is within 10 % of the lumped model (a coarse P2 mesh; the lumped model holds 3 %
  of FE at the default mesh, docs/lumped.md §3.9);
- the README's Python quick start runs and prints the numbers it shows;
- every ``isj`` command of the tutorial and the how-to guides is accepted by the parser;
- the command-line reference lists every subcommand and every option of every parser;
- every public name of the API tables points at a module that the generated pages document;
- every "docs/<page>.md §N.M" cited in the code, tests and docs names a heading of that page
  (section numbers are stable: docs/index.md);
- every page in the navigation exists, or is one the build generates, and every page of docs/
  is in the navigation.
"""

import argparse
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _numbers(line: str) -> list[float]:
    return [float(x) for x in re.findall(r"[-+]?\d+\.\d+", line)]


@pytest.mark.slow
def test_tutorial_python_session(tmp_path):
    script = (DOCS / "examples" / "first_session.py").read_text(encoding="utf-8")
    code = script.split('"""', 2)[2].strip()  # the script without its docstring
    tutorial = (DOCS / "tutorial.md").read_text(encoding="utf-8")
    assert f"```python\n{code}\n```" in tutorial, "docs/tutorial.md shows another session than the script"
    env = dict(os.environ, ISJ_FE_CACHE_DIR=str(tmp_path / "fe"), MPLBACKEND="agg")
    r = subprocess.run(
        [sys.executable, str(DOCS / "examples" / "first_session.py")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    lines = {line.split(":")[0]: line for line in r.stdout.splitlines()}
    a0, b0 = _numbers(lines["default"])
    a5, b5 = _numbers(lines["gap 5 MPa"])
    lo, hi = _numbers(lines["beta over the gap range"])
    afe, bfe = _numbers(lines["FE (P2, coarse)"])
    assert a5 > a0 > 0 and b5 > 0 and b0 > 0  # a softer gap: the joint turns more
    assert lo < hi and lo <= b5 <= hi  # 5 MPa lies inside 2–50 MPa
    assert abs(afe / a5 - 1) < 0.10 and abs(bfe / b5 - 1) < 0.10


def _walk(parser: argparse.ArgumentParser, path: list[str]):
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, [*path, name])


def test_cli_reference_lists_every_command_and_option():
    from isj._cli import build_parser

    text = _load("gen_cli_reference").cli_markdown()
    paths = list(_walk(build_parser(), ["isj"]))
    assert len(paths) > 20  # the groups and their subcommands
    for path, parser in paths:
        assert f"`{' '.join(path)}` {{#{'-'.join(path)}}}" in text, path
        for action in parser._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}" in text or f", {option}" in text, (path, option)


def test_api_tables_point_at_documented_modules(tmp_path):
    gen = _load("gen_api_reference")
    gen.STAGE = tmp_path / "docs-api"  # not the repository's build/
    gen.stage()
    names = gen._all_names("isj")
    assert {"PedicleJointModel", "LumpedModel", "Materials", "Geometry"} <= {n for n, _ in names}
    for package in gen.PACKAGES:
        if (gen._folder(package) / "__init__.py").exists():
            for name, where in gen._all_names(package):
                assert gen._page_of(where), f"{package}.{name} -> {where}: no page documents it"


CITE = re.compile(r"\b([a-z_-]+)\.md\)?\s§(\d+(?:\.\d+)*)")


def _headings(page: Path) -> set[str]:
    found = set()
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#+\s+(\d+(?:\.\d+)*)[\s.]", line + " ")
        if m:
            found.add(m.group(1))
    return found


def test_cited_sections_exist():
    sources = [
        p
        for d in ("isj", "fem", "lumped", "calibration", "reports", "tests", "benchmarks", "examples", "docs")
        for p in (ROOT / d).rglob("*")
        if p.suffix in (".py", ".md")
    ]
    sources += [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    missing = set()
    for src in sources:
        for page, section in CITE.findall(src.read_text(encoding="utf-8")):
            target = DOCS / f"{page}.md"
            if target.exists() and section not in _headings(target):
                missing.add(f"{src.relative_to(ROOT)}: {page}.md §{section}")
    assert not missing, sorted(missing)


def test_nav_pages_exist():
    yaml = pytest.importorskip("yaml")
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    generated = {"reference/cli.md"} | {
        f"reference/modules/{p}.md" for p in _load("gen_api_reference").PACKAGES
    }

    def pages(node):
        if isinstance(node, str):
            yield node
        elif isinstance(node, list):
            for item in node:
                yield from pages(item)
        elif isinstance(node, dict):
            for value in node.values():
                yield from pages(value)

    listed = list(pages(config["nav"]))
    assert "tutorial.md" in listed and "reference/api.md" in listed
    for page in listed:
        assert page in generated or (DOCS / page).exists(), page
    # and every page is reachable from the navigation
    unlisted = sorted(
        str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md") if str(p.relative_to(DOCS)) not in listed
    )
    assert not unlisted, f"pages missing from the nav of mkdocs.yml: {unlisted}"


def _shell_commands(page: Path) -> list[str]:
    """The ``isj ...`` command lines of the ``sh`` code blocks of ``page``."""
    out, block = [], None
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            block = line[3:].strip() if block is None else None
            continue
        if block == "sh":
            cmd = line.split(" #")[0].strip()
            for prefix in (".venv/bin/isj ", "isj "):
                if cmd.startswith(prefix):
                    out.append(cmd[len(prefix) :])
    return out


def test_commands_in_the_guides_parse():
    """Every ``isj`` command the tutorial and the how-to guides show is accepted by the parser."""
    import shlex

    from isj._cli import build_parser
    from isj.errors import UsageError

    pages = [DOCS / "tutorial.md", *sorted((DOCS / "howto").glob("*.md"))]
    commands = [(page.name, c) for page in pages for c in _shell_commands(page)]
    assert len(commands) >= 15
    for name, command in commands:
        args = shlex.split(command)
        if args in (["--version"], ["--help"]):
            continue
        if "-1" in args:  # the tutorial's example of a refused value: refused
            with pytest.raises(UsageError):
                build_parser().parse_args(args)
            continue
        parsed = build_parser().parse_args(args)
        assert callable(parsed.func), (name, command)


@pytest.mark.slow
def test_readme_python_quick_start(tmp_path):
    """The README's Python block runs, and prints what its last comment says (to its 4 digits)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("```python\n", 1)[1].split("```", 1)[0]
    shown = [float(x) for x in block.strip().splitlines()[-1].split("#")[1].split()]
    env = dict(os.environ, ISJ_FE_CACHE_DIR=str(tmp_path / "fe"), MPLBACKEND="agg")
    r = subprocess.run(
        [sys.executable, "-c", block], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600
    )
    assert r.returncode == 0, r.stderr
    printed = [float(x) for x in r.stdout.splitlines()[-1].split()]
    assert len(printed) == len(shown) == 2
    for got, want in zip(printed, shown, strict=True):
        assert abs(got / want - 1) < 1e-3
