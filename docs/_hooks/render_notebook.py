"""The notebook tour (``examples/tour.ipynb``) as a page of the site, executed by the build.

The notebook runs in a Jupyter kernel as the site builds, as a reader runs it (``nbclient``, the kernel's folder
``examples/``): every output on the page is this build's. Its Markdown cells are the page's text, its code cells
Python blocks, and under each block what the cell showed: what it printed, pkmlab's tables (the HTML Jupyter
shows), Plotly figures live (drawn by the copy of Plotly's JavaScript shipped with the ``plotly`` package, so that
the page reads offline). A cell that raises fails the build with the cell's number and the error. The executed
notebook is published beside the page for download.

Outputs are kept out of the Markdown (a raw HTML block with blank lines in it would be read as text): the page
holds a placeholder paragraph per output, replaced by the output's HTML once the Markdown is rendered.
"""

from __future__ import annotations

import html
import json
import logging
import os
import subprocess
import time
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "examples" / "tour.ipynb"
#: The page, the executed notebook beside it, and Plotly's JavaScript (once for the site).
PAGE = "tutorials/tour.md"
DOWNLOAD = "tutorials/tour.ipynb"
PLOTLY_JS = "assets/plotly.min.js"
#: Seconds a cell may take (the Delta's first run compiles its kernels when the cache is cold).
CELL_TIMEOUT = 900

log = logging.getLogger("mkdocs.plugins.pkmlab.render_notebook")
#: The HTML of each output, by its placeholder.
_html: dict[str, str] = {}


def _execute(path: Path = NOTEBOOK):
    """The notebook at ``path``, executed in a new kernel whose folder is the notebook's."""
    import nbclient
    import nbformat

    notebook = nbformat.read(path, as_version=4)
    os.environ.setdefault("MPLBACKEND", "Agg")  # the kernel inherits it: no window opens
    client = nbclient.NotebookClient(notebook, timeout=CELL_TIMEOUT, kernel_name="python3",
                                     resources={"metadata": {"path": str(path.parent)}})
    try:
        # the kernel's own log (its transport, its start) is not the build's: what the cells print and raise comes
        # back through Jupyter's protocol, and a kernel that dies is an error of nbclient's
        client.execute(stderr=subprocess.DEVNULL)
    except nbclient.exceptions.CellExecutionError:
        cells = [c for c in notebook.cells if c.cell_type == "code"]
        for k, cell in enumerate(cells, start=1):
            for output in cell.get("outputs", []):
                if output.output_type == "error":
                    raise PluginError(f"{path.name}: its code cell {k} fails: "
                                      f"{output.ename}: {output.evalue}") from None
        raise
    return notebook


def _plotly_html(spec: dict) -> str:
    import plotly.io as pio

    figure = pio.from_json(json.dumps(spec), skip_invalid=True)
    return pio.to_html(figure, include_plotlyjs=False, full_html=False, auto_play=False,
                       config={"responsive": True})


def _output_html(output) -> str | None:
    """The HTML of one output of a cell, as Jupyter shows it (its richest form the page can show)."""
    if output.output_type == "stream":
        return f'<pre class="pkmlab-output"><code>{html.escape(output.text.rstrip())}</code></pre>'
    data = output.get("data", {})
    if "application/vnd.plotly.v1+json" in data:
        return _plotly_html(data["application/vnd.plotly.v1+json"])
    if "text/html" in data:
        return f'<div class="pkmlab-output">{data["text/html"]}</div>'
    if "image/png" in data:
        return (f'<img class="pkmlab-output" alt="A figure drawn by the cell above, when this page was built." '
                f'src="data:image/png;base64,{data["image/png"].strip()}">')
    if "text/plain" in data:
        return f'<pre class="pkmlab-output"><code>{html.escape(data["text/plain"].rstrip())}</code></pre>'
    return None


def _markdown(notebook) -> str:
    """The page: the Markdown cells as they are, each code cell a Python block and a placeholder per output."""
    _html.clear()
    parts = [f'<script src="../../{PLOTLY_JS}"></script>\n']
    for k, cell in enumerate(notebook.cells):
        if cell.cell_type == "markdown":
            parts.append(cell.source.strip() + "\n")
            if k == 0:  # under the notebook's title
                parts.append("*This page is the notebook [`examples/tour.ipynb`](tour.ipynb), run when this site was "
                             "built: download it and run it in Jupyter.*\n")
        elif cell.cell_type == "code":
            parts.append(f"```python\n{cell.source.strip()}\n```\n")
            for output in cell.get("outputs", []):
                shown = _output_html(output)
                if shown is not None:
                    key = f"PKMLAB_NOTEBOOK_OUTPUT_{len(_html)}"
                    _html[key] = shown
                    parts.append(key + "\n")
    return "\n".join(parts)


def on_files(files, config):
    import nbformat
    from plotly.offline import get_plotlyjs

    start = time.perf_counter()
    notebook = _execute()
    files.append(File.generated(config, PAGE, content=_markdown(notebook)))
    files.append(File.generated(config, DOWNLOAD, content=nbformat.writes(notebook)))
    files.append(File.generated(config, PLOTLY_JS, content=get_plotlyjs()))
    log.info("ran %s in %.1f s", NOTEBOOK.relative_to(ROOT), time.perf_counter() - start)
    return files


def on_page_content(content, page, config, files):
    if page.file.src_uri != PAGE:
        return content
    for key, shown in _html.items():
        content = content.replace(f"<p>{key}</p>", shown, 1)
    return content

