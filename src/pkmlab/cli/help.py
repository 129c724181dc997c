"""``pkmlab help [TOPIC]``: the reference pages shipped with pkmlab, printed as text.

The pages are package data (``pkmlab/help/TOPIC.md``): what a file format's keys mean, what is kept of an output
folder, what an exit code says, can be read wherever pkmlab is installed, without its repository. The
documentation site includes the same pages (``docs/reference/TOPIC.md``), so the two never differ.
"""

from __future__ import annotations

import re

#: Every topic, a page ``pkmlab/help/TOPIC.md``, and what it is about.
TOPICS = {
    "scenario-files": "scenario files (pkmlab simulate): every table and key, plants, sensors, timing, errors",
    "study-files": "study files (pkmlab sweep): grid, uncertainty, jobs, and what a study writes",
    "parameter-files": "parameter files of the paper's 3-RRR (--params, deprecated) and how to convert one",
    "outputs": "output folders, files pkmlab replaces or refuses to, errors and exit codes",
}

_LINK = re.compile(r"\[([^\]]+)\]\(([^)\s#]*)(#[^)\s]*)?\)")
_COMMENT = re.compile(r"<!--.*?-->\n*", re.DOTALL)


def _link(match: re.Match) -> str:
    """A link of the page as text: to another topic, ``text (pkmlab help TOPIC)``; to another page of the
    documentation site, ``text (docs/PAGE.md)``, its path in the repository; within the page, its text."""
    text, target = match.group(1), match.group(2)
    if not target:
        return text
    if target.removesuffix(".md") in TOPICS:
        return f"{text} (pkmlab help {target.removesuffix('.md')})"
    parts = ["docs", "reference"]  # the pages' links are relative to docs/reference/, where the site includes them
    for part in target.split("/"):
        if part == "..":
            parts.pop()
        elif part not in ("", "."):
            parts.append(part)
    return f"{text} ({'/'.join(parts)})"


def page(topic: str) -> str:
    """The page of ``topic`` as text: its Markdown, each link followed by where it leads (:func:`_link`), without
    the comments meant for the site's sources."""
    from importlib.resources import files

    text = (files("pkmlab") / "help" / f"{topic}.md").read_text(encoding="utf-8")
    return _LINK.sub(_link, _COMMENT.sub("", text))


def cmd_help(args) -> None:
    """``help [TOPIC]``: the page of TOPIC, or the list of topics."""
    if args.topic is None:
        width = max(map(len, TOPICS))
        print("pkmlab help TOPIC prints a reference page shipped with pkmlab (the documentation site has them all):")
        for topic, about in TOPICS.items():
            print(f"  {topic:<{width}}  {about}")
        print("Every command's options: pkmlab COMMAND -h.")
        return
    print(page(args.topic), end="")
