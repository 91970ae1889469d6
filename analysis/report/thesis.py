"""The thesis' own numbers, for the report to put beside ours (section numbers cited)."""

from __future__ import annotations

# §3.3.1, §3.3.2, §3.4: force-deflection reference points (kind, kPa, mm) -> N
FORCE_POINTS = {("reduced", 0.0, 30.0): 359.0, ("full", 80.0, 25.0): 3933.0,
                ("full", 200.0, 30.0): 4476.0}

# §3.3.1: reduced model at 30 mm
REDUCED_30 = {"Fz N": 359.0, "contact nodes": 14, "mean nodal force N": 25.68,
              "std nodal force N": 7.27}

# §3.3.2: full model at 30 mm / 80 kPa (the text's typical experiment; Fig. 3.2)
FULL_30_80 = {"bulge at 200 kPa (mm)": 8.0, "real tyre bulge at 200 kPa (mm)": 4.0}
# §3.3.2, same experiment: "an average nodal force of 263.3N" and "standard deviation of
# 227.4N" over the loaded nodes - per node, so they scale with the thesis' node spacing
FULL_30_80_NODAL = {"mean nodal force N": 263.3, "std nodal force N": 227.4}

# Table 3.1
TABLE_3_1 = [
    ("road boundary condition", "iterative procedure", "hard contact, exponential penalty"),
    ("internal pressure", "no", "yes"),
    ("Young's modulus tread / sidewall / bead (MPa)", "10 / 10 / 10", "60 / 20 / 20"),
    ("Poisson's ratio", "0.499", "0.4"),
    ("number of elements", "440", "880"),
]

# §5.4, §5.5: cumulative % of output variance explained by modes 1-3
PCR_CUMULATIVE = (64.0, 78.0, 91.0)
PLSR_CUMULATIVE = {"displacement": (53.8, 79.5, 95.2), "strain": (52.9, 79.6, 96.9)}

# Table 5.1: PLSR totals with and without noise (Fz N, Mx N m, My N m; +- nodal-average std)
TABLE_5_1 = [
    ("reference", 4475.70, 0.0, 0.0, None),
    ("displacement", 4475.70, 0.0, 0.0, None),
    ("strain", 4475.70, 0.0, 0.0, None),
    ("displacement + N(0, 1)", 4471.10, 0.036, 0.032, 133.13),
    ("strain + N(0, 0.04 %)", 4485.20, 0.017, 0.026, 149.28),
]

# Tables 4.1-4.4 and the chapter-4 nodal-error spreads: analysis/report/ch4_thesis.py
