"""The reporting room: every table and figure the farm shows, computed from the store.

- :mod:`.tables`, :mod:`.plots`, :mod:`.markdown`: the chapter-5 analyses' CSV tables,
  PNG figures and Markdown summaries;
- :mod:`.ch3`: force-deflection validation, Table 3.1 (thesis ch. 3);
- :mod:`.ch4`, :mod:`.ch4_thesis`: Tables 4.1-4.4 and Figs. 4.2/4.3 from an inverse-solves
  group (thesis ch. 4);
- :mod:`.ch5`: the chapter-5 stage of the reproduction;
- :mod:`.calibration`: the calibration's force-deflection figure;
- :mod:`.thesis`: the thesis' own numbers; :mod:`.reproduction`: the reproduction report.

Everything here reads through :mod:`storage` only (never farm or jobs).
"""
