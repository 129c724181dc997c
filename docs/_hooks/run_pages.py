"""The tutorials and how-to guides run as they are written, and their figures are drawn by the build.

Every ```` ```python ```` block of a page under ``tutorials/`` or ``how-to/`` is executed when the site is built:
the blocks of a page in order, in one namespace (as a reader pastes them into one session), in a scratch folder
whose ``examples/`` is the repository's (the blocks' relative paths are those of a checkout; what they write stays
there). What a block prints is shown under it, and every Matplotlib figure it leaves open is saved into the site
and shown under it: no output or figure is pasted. A block that raises fails the build with the page, the block's
number and the error. A block that only includes a file (``--8<--``) is left alone: the file is run by the tests.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import re
import tempfile
import time
import traceback
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
#: The folders whose pages run.
RUN = ("tutorials/", "how-to/")
#: A fenced Python block: the fence, the code, the closing fence.
BLOCK = re.compile(r"^```python[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
#: The resolution of the figures (dots per inch): sharp on a laptop's screen, a few tens of kB each.
DPI = 110

log = logging.getLogger("mkdocs.plugins.pkmlab.run_pages")
#: What each page's blocks printed and drew: ``{src_uri: [(printed, [figure uri, ...]), ...]}``.
_outputs: dict[str, list[tuple[str, list[str]]]] = {}


def _blocks(markdown: str) -> list[re.Match]:
    return [m for m in BLOCK.finditer(markdown) if not m.group(1).lstrip().startswith("--8<--")]


def _run_page(uri: str, markdown: str, config, files) -> list[tuple[str, list[str]]]:
    import matplotlib

    matplotlib.use("Agg")  # files only, whatever the builder's display
    import matplotlib.pyplot as plt

    outputs = []
    namespace = {"__name__": "__main__"}
    stem = Path(uri).stem
    folder = Path(uri).parent.as_posix()
    here = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="pkmlab-docs-") as scratch:
        os.symlink(ROOT / "examples", Path(scratch) / "examples")
        os.chdir(scratch)
        try:
            for k, match in enumerate(_blocks(markdown), start=1):
                printed = io.StringIO()
                before = set(plt.get_fignums())  # a figure open already is not this block's
                try:
                    with contextlib.redirect_stdout(printed):
                        exec(compile(match.group(1), f"{uri}, block {k}", "exec"), namespace)  # noqa: S102
                except Exception as exc:  # noqa: BLE001 - any error of a block is the page's
                    trace = "".join(traceback.format_exception(exc)[-3:]).strip()
                    raise PluginError(f"{uri}: its Python block {k} fails as written:\n{trace}") from None
                figures = []
                drawn = [number for number in plt.get_fignums() if number not in before]
                for j, number in enumerate(drawn, start=1):
                    data = io.BytesIO()
                    plt.figure(number).savefig(data, format="png", dpi=DPI)
                    plt.close(number)
                    name = f"{folder}/plots/{stem}-{k}-{j}.png"
                    files.append(File.generated(config, name, content=data.getvalue()))
                    figures.append(name)
                outputs.append((printed.getvalue(), figures))
        finally:
            os.chdir(here)
    return outputs


def on_files(files, config):
    for file in list(files):
        uri = file.src_uri
        if uri.endswith(".md") and uri.startswith(RUN) and file.abs_src_path:
            start = time.perf_counter()
            _outputs[uri] = _run_page(uri, Path(file.abs_src_path).read_text(encoding="utf-8"), config, files)
            log.info("ran the Python of %s in %.1f s", uri, time.perf_counter() - start)
    return files


def on_page_markdown(markdown, page, config, files):
    outputs = _outputs.get(page.file.src_uri)
    if not outputs:
        return markdown
    parts, end = [], 0
    for match, (printed, figures) in zip(_blocks(markdown), outputs, strict=True):
        parts.append(markdown[end:match.end()])
        if printed.strip():
            parts.append('\n\n```text title="Output"\n' + printed.rstrip() + "\n```")
        for name in figures:
            relative = os.path.relpath(name, Path(page.file.src_uri).parent.as_posix())
            parts.append(f"\n\n![A figure drawn by the code above, when this page was built.]({relative})")
        end = match.end()
    return "".join(parts) + markdown[end:]
