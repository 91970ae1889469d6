"""MkDocs hooks of the documentation site (mkdocs.yml): README.md is its home page.

README links into docs/ (``docs/guide/models.md``); on the site those pages sit at the
root, so the links lose their ``docs/`` prefix. Nothing else is rewritten.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File, Files

README = Path(__file__).resolve().parents[1] / "README.md"


def on_files(files: Files, config) -> Files:
    files.append(File.generated(config, "index.md", content=README.read_text(encoding="utf-8")))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri != "index.md":
        return markdown
    return re.sub(r"\]\(docs/", "](", markdown)
