"""A pandas DataFrame as a rich table on the terminal (the CLI's tables of results)."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table


def print_frame(console: Console, title: str, frame, digits: int = 3) -> None:
    """Columns right-aligned, floats to ``digits`` significant digits, missing as '-'."""
    table = Table(title=title)
    for col in frame.columns:
        table.add_column(str(col), justify="right")
    for row in frame.itertuples(index=False):
        table.add_row(*(_cell(v, digits) for v in row))
    console.print(table)


def _cell(value, digits: int) -> str:
    if value is None or (isinstance(value, float) and value != value):
        return "-"
    return f"{value:.{digits}g}" if isinstance(value, float) else str(value)
