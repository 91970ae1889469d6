"""Rendering shared by the studies and the report: tables, figures and Markdown.

- :mod:`.tables`: the chapter-5 result tables (pandas, long format for CSV);
- :mod:`.plots`: their PNG figures;
- :mod:`.markdown`: Markdown tables and summaries;
- :mod:`.provenance`: the command, commit and machine load a study's results came from.

It sits below both users - ``studies -> render``, ``report -> studies, render`` - and
imports neither, so the two never import each other back (tests/test_layering.py).
"""
