"""Write a Drake diagram's picture: Graphviz source, and SVG when the ``dot`` program is available."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any


def write_diagram_graph(diagram: Any, path_stem: str | Path, max_depth: int = 1) -> list[Path]:
    """Write ``<stem>.dot`` (``diagram.GetGraphvizString``) and, when ``dot`` is installed, ``<stem>.svg``.

    Args:
        diagram: A built Drake ``Diagram`` (anything with ``GetGraphvizString(max_depth=...)``).
        path_stem: Output path without suffix; missing parent folders are created.
        max_depth: How many levels of nested diagrams to expand (>= 0).

    Returns:
        The paths written, ``.dot`` first. The SVG is skipped quietly when ``dot`` is not on PATH
        or fails.
    """
    if not isinstance(max_depth, int) or isinstance(max_depth, bool) or max_depth < 0:
        raise ValueError(f"write_diagram_graph.max_depth: expected an integer >= 0, got {max_depth!r}")
    if not hasattr(diagram, "GetGraphvizString"):
        raise ValueError(
            f"write_diagram_graph.diagram: expected a Drake Diagram, got {type(diagram).__name__}"
        )
    stem = Path(path_stem)
    if stem.name in ("", ".", ".."):
        raise ValueError(f"write_diagram_graph.path_stem: expected a file stem, got {str(path_stem)!r}")
    stem.parent.mkdir(parents=True, exist_ok=True)
    dot_path = stem.parent / f"{stem.name}.dot"
    dot_path.write_text(diagram.GetGraphvizString(max_depth=max_depth))
    written = [dot_path]
    dot = shutil.which("dot")
    if dot is not None:
        svg_path = stem.parent / f"{stem.name}.svg"
        try:
            subprocess.run(
                [dot, "-Tsvg", str(dot_path), "-o", str(svg_path)],
                check=True,
                capture_output=True,
                timeout=60,
            )
        except (subprocess.CalledProcessError, subprocess.TimeoutExpired, OSError):
            svg_path.unlink(missing_ok=True)
        else:
            written.append(svg_path)
    return written
