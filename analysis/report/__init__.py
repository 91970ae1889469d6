"""The reporting room: every table and figure the farm shows, computed from the store.

- :mod:`.ch3`: force-deflection validation, Table 3.1 (thesis ch. 3);
- :mod:`.ch4`, :mod:`.ch4_thesis`: Tables 4.1-4.4 and Figs. 4.2/4.3 from an inverse-solves
  group (thesis ch. 4); :mod:`.ch4_extra`: issue 16's tables beyond the thesis (initial
  guesses, regularisation);
- :mod:`.ch5`: the chapter-5 stage of the reproduction;
- :mod:`.calibration`: the calibration's force-deflection figure;
- :mod:`.thesis`: the thesis' own numbers; :mod:`.reproduction`: the reproduction report,
  with :mod:`.stage` (what a stage hands in), :mod:`.findings` (the headline numbers
  beside the thesis'), :mod:`.table_5_1` (Table 5.1 beside the thesis) and
  :mod:`.readable` (headers, missing values and round-off as the report prints them).

The chapter-5 tables, figures and Markdown helpers the studies share live in
:mod:`analysis.render` (below both the studies and this package, so neither imports the
other back). Everything here reads through :mod:`storage` only (never farm or jobs).
"""
