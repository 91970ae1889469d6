"""Short Markdown summaries (no extra dependency: pandas' ``to_markdown`` needs tabulate)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd


def table(frame: pd.DataFrame, digits: int = 4) -> str:
    """GitHub-flavoured Markdown table; floats to ``digits`` significant digits."""

    def cell(v) -> str:
        if isinstance(v, float | np.floating):
            return f"{v:.{digits}g}"
        return str(v)

    head = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([head, rule, *body])


def write(path: Path, title: str, sections: Sequence[tuple[str, str | pd.DataFrame]]) -> Path:
    """Write ``# title`` then ``## heading`` + text or table per section."""
    lines = [f"# {title}", ""]
    for heading, body in sections:
        lines += [f"## {heading}", ""]
        lines += [table(body) if isinstance(body, pd.DataFrame) else str(body), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines))
    return path


def figure(path: Path, relative_to: Path, caption: str) -> str:
    """Markdown image link relative to the summary's folder."""
    return f"![{caption}]({path.relative_to(relative_to).as_posix()})"
