"""The glossary page, written at build time from §0 of ``docs/conventions.md``.

The glossary stays where docstrings and the changelog point to it (conventions §0); the page holding the
marker ``<!-- pkmlab:glossary -->`` shows the same text, so that it is one click away and never a second copy
to keep in step.
"""

from __future__ import annotations

import re
from pathlib import Path

MARKER = "<!-- pkmlab:glossary -->"
CONVENTIONS = Path(__file__).resolve().parents[1] / "conventions.md"


def glossary(path: Path = CONVENTIONS) -> str:
    text = path.read_text(encoding="utf-8")
    found = re.search(r"^## 0\. Glossary\n(.*?)(?=^## 1\.)", text, flags=re.MULTILINE | re.DOTALL)
    if found is None:
        raise ValueError(f"{path}: no section '## 0. Glossary' followed by '## 1.'")
    # One level up: the conventions' ### subsections are this page's ## sections.
    return re.sub(r"^###", "##", found.group(1).strip(), flags=re.MULTILINE) + "\n"


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, glossary())
