"""The thesis' Tables 4.1-4.4, verbatim, to print beside the farm's numbers.

Keys are (condition, method) with the condition names of the thesis' inverse study as
the farm names them (``ideal``, ``noise``, ``guess-90``, ``guess-uniform``: the
defaults of an inverse study file, ``docs/inverse.md``). Fz in N, moments in N m,
displacement RMSE in mm, strain RMSE in microstrain; ``None`` where the thesis gives no
spread. The reference experiment: Fz = 359.08 N, Mx = My = 0. Nodal-force error
spreads (Figs. 4.2, 4.3, std in N) and the largest reference nodal force (35.5 N) are
quoted from §4.4-4.5.
"""

from __future__ import annotations

REFERENCE_FZ = 359.08
MAX_NODAL_FORCE = 35.5

# (condition, method): (Fz, Fz_std, Mx, Mx_std, My, My_std)
FORCES = {
    ("ideal", "displacement"): (359.23, None, -0.840, None, -0.019, None),
    ("ideal", "strain"): (356.71, None, -0.15, None, -0.25, None),
    ("noise", "displacement"): (358.28, 0.4, -0.84, 0.1, -0.020, 0.05),
    ("noise", "strain"): (357.40, 0.9, -0.2, 0.02, -0.27, 0.01),
    ("guess-90", "displacement"): (358.6, 4, -0.933, 1.3, 0.03853, 0.4),
    ("guess-90", "strain"): (356.6, 5, -1.239, 2, -0.1884, 1),
    ("guess-uniform", "displacement"): (364.0, 2, -1.694, 2, -0.6371, 0.2),
    ("guess-uniform", "strain"): (357.1, 2, -1.659, 0.5, 0.07057, 0.4),
}

# (condition, method): (Ux, Uy, Uz [mm], exx, eyy, exy [microstrain])
RMSE = {
    ("ideal", "displacement"): (0.0075, 0.012, 0.049, 116.60, 172.07, 138.53),
    ("ideal", "strain"): (0.030, 0.19, 0.24, 485.70, 560.16, 252.52),
    ("noise", "displacement"): (0.010, 0.040, 0.070, 131.08, 171.22, 147.54),
    ("noise", "strain"): (0.27, 1.93, 2.25, 4538.7, 5089.14, 2530.81),
    ("guess-90", "displacement"): (0.03227, 0.08697, 0.1997, 284.4, 351.9, 226.2),
    ("guess-90", "strain"): (0.05158, 0.4087, 0.4987, 911, 1029, 487.2),
    ("guess-uniform", "displacement"): (0.1041, 0.6276, 0.8744, 1569, 1895, 1082),
    ("guess-uniform", "strain"): (0.0446, 0.4657, 0.4825, 930, 1027, 401.8),
}

# (condition, method): std of the nodal force errors, N (Figs. 4.2, 4.3)
NODAL_ERROR_STD = {
    ("noise", "displacement"): 2.0,
    ("noise", "strain"): 3.2,
    ("guess-90", "displacement"): 16.4,
    ("guess-90", "strain"): 11.6,
    ("guess-uniform", "displacement"): 16.8,
    ("guess-uniform", "strain"): 13.3,
}

TABLE = {
    "ideal": "4.1/4.2", "noise": "4.1/4.2", "guess-90": "4.3/4.4", "guess-uniform": "4.3/4.4",
}
