"""The command-line reference, generated from the argparse parsers of :mod:`isj._cli`.

Used two ways:

- as a mkdocs hook (``hooks:`` in ``mkdocs.yml``): :func:`on_files` adds the page
  ``reference/cli.md`` to the site at build time, so it is never stored and cannot go stale;
- as a script: ``.venv/bin/python docs/gen_cli_reference.py`` prints the same markdown.

Every command, subcommand and option that ``isj`` accepts appears, with its help text,
default and choices as ``isj ... --help`` prints them.
"""

from __future__ import annotations

import argparse

#: Site path of the generated page.
CLI_PAGE = "reference/cli.md"


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of each subcommand of ``parser``, in ``--help`` order."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            for name, sub in action.choices.items():
                out.append((name, helps.get(name, ""), sub))
    return out


def _option_rows(parser: argparse.ArgumentParser) -> list[tuple[str, str]]:
    """(invocation, expanded help) of each argument of ``parser`` except ``-h`` and subcommands."""
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        if action.help is argparse.SUPPRESS:
            continue
        invocation = formatter._format_action_invocation(action)
        text = formatter._expand_help(action) if action.help else ""
        rows.append((invocation, " ".join(text.split())))
    return rows


def _cell(text: str) -> str:
    """``text`` safe inside a markdown table cell."""
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _anchor(path: list[str]) -> str:
    return "-".join(path)


def _section(path: list[str], helptext: str, parser: argparse.ArgumentParser, level: int) -> list[str]:
    lines = [f"{'#' * level} `{' '.join(path)}` {{#{_anchor(path)}}}", ""]
    if helptext:
        lines += [helptext[:1].upper() + helptext[1:] + ("" if helptext.endswith(".") else "."), ""]
    if parser.description and parser.description != helptext:
        lines += [" ".join(parser.description.split()), ""]
    usage = parser.format_usage().rstrip().removeprefix("usage: ").splitlines()
    usage = [usage[0], *(line[len("usage: ") :] for line in usage[1:])]
    lines += ["```text", *usage, "```", ""]
    rows = _option_rows(parser)
    if rows:
        lines += ["| argument | meaning |", "|---|---|"]
        lines += [f"| `{_cell(inv)}` | {_cell(text)} |" for inv, text in rows]
        lines.append("")
    subs = _subcommands(parser)
    if subs:
        lines += ["| subcommand | what it does |", "|---|---|"]
        lines += [f"| [`{name}`](#{_anchor([*path, name])}) | {_cell(h)} |" for name, h, _ in subs]
        lines.append("")
        for name, h, sub in subs:
            lines += _section([*path, name], h, sub, min(level + 1, 4))
    return lines


def cli_markdown() -> str:
    """The whole command-line reference as one markdown page."""
    from isj._cli import build_parser

    parser = build_parser()
    head = [
        "# Command-line reference",
        "",
        "Generated from the parsers of `isj._cli` when the site is built "
        "(`docs/gen_cli_reference.py`): every command and option `isj` accepts. "
        "Units are SI; bad input is one line naming the parameter, exit code 2 "
        "([user guide §6.8](../user-guide.md#68-errors-and-exit-codes)).",
        "",
    ]
    body = _section(["isj"], "", parser, 2)
    return "\n".join(head + body).rstrip() + "\n"


def on_files(files, config):
    """mkdocs hook: add the generated command-line reference to the site's files."""
    from mkdocs.structure.files import File

    files.append(File.generated(config, CLI_PAGE, content=cli_markdown()))
    return files


if __name__ == "__main__":  # pragma: no cover
    print(cli_markdown(), end="")
