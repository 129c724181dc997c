"""The command line reference, written at build time from the parser itself (``pkmlab.cli._parser.build_parser``).

A page holding the marker ``<!-- pkmlab:cli-reference -->`` gets, in its place, one section per command: its
summary, its usage line and a table of its arguments, all read from argparse, so the reference cannot drift
from what ``pkmlab --help`` says.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

MARKER = "<!-- pkmlab:cli-reference -->"
# Usage lines wrapped at a fixed width, so the page does not depend on the terminal that builds it.
WIDTH = 100

# The documented pkmlab is this checkout's, even where another one is installed.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))


def _cell(text: str) -> str:
    """Text for one cell of a Markdown table: a pipe outside code is escaped (inside code, the table reads it
    as text already, and an escape would show)."""
    parts = re.split(r"(`[^`]*`)", " ".join(str(text).split()))
    return "".join(part if part.startswith("`") else part.replace("|", "\\|") for part in parts)


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = argparse.HelpFormatter(prog=parser.prog, width=WIDTH)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip()


def _argument(action: argparse.Action) -> str:
    if action.option_strings:
        names = ", ".join(f"`{s}`" for s in action.option_strings)
        if action.nargs == 0:  # a flag
            return names
        metavar = action.metavar or action.dest.upper()
        if action.nargs in ("+", "*"):
            metavar = f"{metavar} ..."
        return f"{names} `{metavar}`"
    name = action.metavar or action.dest
    return f"`{name} ...`" if action.nargs in ("+", "*") else f"`{name}`"


def _arguments_table(parser: argparse.ArgumentParser) -> list[str]:
    rows = []
    for action in parser._actions:
        if action.help == argparse.SUPPRESS or isinstance(action, argparse._SubParsersAction):
            continue
        if isinstance(action, argparse._HelpAction):
            continue  # every command has -h; said once at the top of the page
        details = action.help or ""
        if action.required and action.option_strings:
            details = f"required; {details}"
        if action.choices is not None:
            details += f" (one of: {', '.join(str(c) for c in action.choices)})"
        rows.append(f"| {_cell(_argument(action))} | {_cell(details)} |")
    if not rows:
        return []
    return ["| argument | meaning |", "| --- | --- |", *rows]


def cli_reference() -> str:
    from pkmlab.cli._parser import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    summaries = {a.dest: a.help for a in sub._choices_actions}
    lines = [parser.description or "", "", "```text", _usage(parser), "```", "", *_arguments_table(parser), "",
             "| command | what it does |", "| --- | --- |"]
    lines += [f"| [`{name}`](#pkmlab-{name}) | {_cell(summaries.get(name, ''))} |" for name in sub.choices]
    for name, command in sub.choices.items():
        lines += ["", f"## `pkmlab {name}` {{ #pkmlab-{name} }}", "", summaries.get(name) or "", "",
                  "```text", _usage(command), "```", ""]
        if command.description:
            lines += [command.description, ""]
        lines += _arguments_table(command)
    return "\n".join(lines) + "\n"


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, cli_reference())


if __name__ == "__main__":  # the generated Markdown, to read it without building the site
    print(cli_reference())
