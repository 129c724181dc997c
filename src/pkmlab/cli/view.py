"""``pkmlab view``: the interactive HTML view of a result folder."""

from __future__ import annotations

from pathlib import Path

from ..errors import PkmlabError
from ._common import NewFolders, output_path


def cmd_view(args) -> dict:
    """The interactive HTML view of a result folder: RESULT_DIR/REPORT.html (listed in its manifest) or --out."""
    from ..views.folder import read_result_views
    from ..views.html import write_html

    folder = Path(args.result_dir)
    out = output_path(args.out, "--out", {".html", ".htm"}, args.force) if args.out else folder / "REPORT.html"
    views = read_result_views(folder)  # every file checked before anything is written
    title = f"pkmlab view: {folder.resolve().name}"
    if args.out:
        try:
            with NewFolders(out):
                write_html(out, views, title)
        except OSError as exc:
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}") from None
    else:
        from ..outputs import OutputFolderError, add_to_result
        from ..views.html import page

        text = page(views, title)
        try:
            add_to_result(folder, "REPORT.html", lambda tmp: tmp.write_text(text, encoding="utf-8"))
        except OutputFolderError as exc:
            raise PkmlabError(f"{exc}; write the view elsewhere with --out FILE.html") from None
        except OSError as exc:  # a read-only result, a full disk
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}; write the view elsewhere with --out "
                              "FILE.html") from None
    size = out.stat().st_size
    result = {"html": str(out), "runs": [v.name for v in views], "bytes": size}
    if not args.json:
        print(f"wrote {out} ({size / 1e6:.1f} MB, {len(views)} run{'s' if len(views) > 1 else ''}: "
              f"{', '.join(v.name for v in views)}); open it in a browser, it works offline")
    return result
