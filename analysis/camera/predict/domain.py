"""What a force model knows: is a measured cloud like those it was trained on? (issue 47)

A learner extrapolates without a word: ``farm predict`` printed Fx = 6.6e299 N for a cloud
with one coordinate of 1e300, and confident forces for the clouds of a 0.7x or 1.5x tyre
and for a cloud 500 mm off. Two questions are asked before a force is believed:

1. **Is the reference cloud this tyre, in the model's frame?**
   (:func:`reference_checks`, once per call):
   - its points' RMS offset from the model's inner surface, at each point's own (theta, s)
     (:data:`MAX_OFFSET_MM`);
   - the share of the sensor's layout its footprint covers (:data:`MIN_COVERAGE`): a
     smaller tyre's window, registered into this one, leaves the layout's edges bare.

   A failure refuses the call: no cloud of it is featurised.
2. **Is each deformation like a trained one?** (:class:`FeatureDomain`). The standard
   monitoring statistics of a latent-variable model (Jackson & Mudholkar 1979; Nomikos &
   MacGregor 1995, Technometrics 37(1)): on standardised features, principal components
   keeping :attr:`FeatureDomain.variance` of the training variance, Hotelling's T² (how
   far along the trained directions, in their own spread) and Q, the squared residual
   off them (a deformation no training cloud has). Limits: :attr:`~FeatureDomain.margin`
   times the largest value of any training or held-out row, so that every cloud the
   model was fitted or checked on is inside by construction and a limit is a measured
   fact, not a distribution assumed.

A cloud outside gets unbounded intervals and the measure that failed
(:meth:`analysis.camera.predictor.ForceModel.predict_clouds`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from analysis.camera.sensor.layout import Layout, face_weights
from analysis.camera.sensor.surface import InnerSurface
from analysis.errors import CloudError, ParameterError

__all__ = ["MAX_OFFSET_MM", "MIN_COVERAGE", "FeatureDomain", "coverage", "reference_checks",
           "surface_offset"]

MAX_OFFSET_MM = 10.0
"""Largest RMS offset (mm) of a reference cloud from the model's inner surface. A cloud of
this tyre is the surface plus the camera's noise (hundredths of a mm) plus, for a real
reference, the inflation growth the model's reference leaves out (1.7-4.4 mm at 80-200
kPa for the credible presets, docs/mesh-convergence.md) and a registration's error; a
0.7x or 1.5x tyre or a cloud in another frame is tens to thousands of mm off."""

MIN_COVERAGE = 0.9
"""Smallest share of the sensor's layout points that must lie within the reference
cloud's footprint (a layout point farther than two of the cloud's point spacings from
every cloud point, in (crown arc length, s), is bare: its values would be extrapolated)."""


def _coordinates(surface: InnerSurface, ref_points: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(theta, s) of the points, NaN where they are too large to place."""
    from analysis.camera.sensor.resample import surface_coordinates

    with np.errstate(over="ignore", invalid="ignore"):
        return surface_coordinates(surface, ref_points)


def surface_offset(surface: InnerSurface, ref_points: np.ndarray,
                   coordinates: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """RMS distance (mm) of reference points (M, 3) from ``surface`` at their own
    surface coordinates (given, or computed); ``inf`` where they are too large to place."""
    theta, s = coordinates or _coordinates(surface, ref_points)
    if not (np.isfinite(theta).all() and np.isfinite(s).all()):
        return float("inf")
    with np.errstate(over="ignore", invalid="ignore"):
        offset = ref_points - face_weights(surface, theta, s) @ surface.node_xyz
        rms = float(np.sqrt(np.mean(np.sum(offset**2, axis=1))))
    return rms if np.isfinite(rms) else float("inf")


def coverage(surface: InnerSurface, layout: Layout, ref_points: np.ndarray,
             coordinates: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """Share of ``layout``'s points within two point spacings of the reference cloud,
    both in (arc length at the crown's radius, s)."""
    theta, s = coordinates or _coordinates(surface, ref_points)
    R = surface.crown_radius
    known = np.column_stack([R * theta, s])
    known = known[np.isfinite(known).all(axis=1)]
    if known.shape[0] < 2:
        return 0.0
    tree = cKDTree(known)
    spacing = float(np.median(tree.query(known, k=2)[0][:, 1]))
    T, S = np.meshgrid(layout.theta, layout.s)
    wanted = np.column_stack([R * T.ravel(), S.ravel()])
    dist, _ = tree.query(wanted)
    return float(np.mean(dist <= 2.0 * max(spacing, 1e-9)))


def reference_checks(surface: InnerSurface, layout: Layout, ref_points: np.ndarray) -> dict:
    """The reference cloud's offset and coverage; raises :class:`CloudError` naming the
    measure that failed, its value, its limit and the likely fix."""
    coordinates = _coordinates(surface, ref_points)  # placed once for both measures
    offset = surface_offset(surface, ref_points, coordinates)
    if not offset <= MAX_OFFSET_MM:
        raise CloudError(
            f"the reference cloud lies {offset:.4g} mm (RMS) from the model's inner surface, "
            f"a cloud of this tyre within {MAX_OFFSET_MM:g} mm: it is another tyre or not in "
            "the model's frame; register it (--align, or --transform) or use a model "
            "trained on this tyre")
    covered = coverage(surface, layout, ref_points, coordinates)
    if covered < MIN_COVERAGE:
        raise CloudError(
            f"the reference cloud covers {100 * covered:.0f} % of the sensor's window (at "
            f"least {100 * MIN_COVERAGE:.0f} % needed): it is a smaller tyre or a smaller "
            "field of view than the model was trained on; give the whole window's cloud")
    return {"offset_mm": offset, "coverage": covered}


@dataclass
class FeatureDomain:
    """Hotelling's T² and Q of feature rows against the training features.

    Parameters
    ----------
    variance : float
        Share of the standardised training variance the components keep.
    margin : float
        A limit is this many times the largest training or held-out value.

    Attributes
    ----------
    mean_, scale_ : ndarray, shape (F,)
        Standardisation of the features (a constant feature keeps scale 1).
    components_ : ndarray, shape (k, F)
        Principal directions of the standardised training rows.
    variances_ : ndarray, shape (k,)
        Their training variances.
    t2_limit_, q_limit_ : float
        The limits.
    t2_fit_limit_, q_fit_limit_ : float
        The limits of the fitted rows alone (what :meth:`difficulty` divides by).
    reference_ : float
        The median raw difficulty of the check rows (1 without them): what
        :meth:`difficulty` is relative to.
    """

    variance: float = 0.99
    margin: float = 2.0

    def fit(self, X: np.ndarray, X_check: np.ndarray | None = None) -> FeatureDomain:
        """Learn the domain of ``X`` (n, F); ``X_check`` (m, F), rows the model was checked
        on but not fitted to, join the limits only."""
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[0] < 2:
            raise ParameterError(f"a feature domain needs at least 2 rows (n, F), got "
                                 f"{X.shape}")
        if not 0.0 < self.variance <= 1.0 or not self.margin >= 1.0:
            raise ParameterError(f"variance must be in (0, 1] and margin >= 1, got "
                                 f"{self.variance}, {self.margin}")
        self.mean_ = X.mean(axis=0)
        scale = X.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        Z = (X - self.mean_) / self.scale_
        _, sv, vt = np.linalg.svd(Z, full_matrices=False)
        var = sv**2 / (X.shape[0] - 1)
        share = np.cumsum(var) / max(var.sum(), 1e-300)
        k = int(np.searchsorted(share, self.variance - 1e-12) + 1)
        k = max(1, min(k, int(np.sum(var > 1e-12 * var[0]))))
        self.components_, self.variances_ = vt[:k], var[:k]
        self.t2_fit_limit_, self.q_fit_limit_ = self._limits(X)
        self.reference_ = 1.0
        if X_check is None:
            self.t2_limit_, self.q_limit_ = self.t2_fit_limit_, self.q_fit_limit_
            return self
        X_check = np.asarray(X_check, dtype=float)
        self.t2_limit_, self.q_limit_ = self._limits(np.vstack([X, X_check]))
        # Rows a domain was not fitted on sit far beyond its fitted rows' limits when the
        # rows are fewer than the features (their Q is in-sample, nearly zero), by how
        # far depends on how many rows were fitted: a fold's domain and the model's would
        # not agree. Relative to unseen rows' typical value they do.
        self.reference_ = float(np.median(self.difficulty(X_check)))
        return self

    def _limits(self, rows: np.ndarray) -> tuple[float, float]:
        t2, q = self.scores(rows)
        return (float(self.margin * t2.max()),
                float(self.margin * max(q.max(), 1e-12 * len(self.mean_))))

    def scores(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """T² and Q, each (n,), of feature rows ``X`` (n, F); ``inf`` where not finite."""
        with np.errstate(over="ignore", invalid="ignore"):
            Z = (np.asarray(X, dtype=float) - self.mean_) / self.scale_
            T = Z @ self.components_.T
            t2 = np.sum(T**2 / self.variances_, axis=1)
            q = np.sum((Z - T @ self.components_) ** 2, axis=1)
        bad = ~(np.isfinite(t2) & np.isfinite(q))
        t2[bad], q[bad] = np.inf, np.inf
        return t2, q

    def difficulty(self, X: np.ndarray) -> np.ndarray:
        """(n,) ``(1 + T2 / L_T2 + Q / L_Q) / reference_`` of feature rows ``X`` (n, F),
        the limits those of the fitted rows alone (``fit``'s ``X``, not its check rows),
        relative to the check rows' median (1: as unlike the training rows as a typical
        unseen row); ``inf`` where not finite. The scale of normalised conformal
        intervals (issue 47: wider where a cloud is unlike the training clouds;
        :class:`~analysis.camera.predict.intervals.ConformalIntervals`). Out-of-fold rows
        are scaled against a domain of their fold's fitted rows checked on themselves, a
        new cloud against the model's checked on its held-out rows, so that both are rows
        the domain was not fitted on, in the same units."""
        t2, q = self.scores(X)
        return (1.0 + t2 / self.t2_fit_limit_ + q / self.q_fit_limit_) / self.reference_

    def outside(self, X: np.ndarray) -> list[str]:
        """Per row: '' inside, else the measures over their limits, e.g.
        ``"Q 8.1x its limit"``."""
        t2, q = self.scores(X)
        out = []
        for a, b in zip(t2, q, strict=True):
            over = [f"{name} {value / limit:.3g}x its limit" for name, value, limit in
                    (("T2", a, self.t2_limit_), ("Q", b, self.q_limit_)) if value > limit]
            out.append("; ".join(over))
        return out

    def to_dict(self) -> dict:
        """Plain arrays and numbers (what a model file may hold without new trusted
        types)."""
        return {"variance": self.variance, "margin": self.margin, "mean": self.mean_,
                "scale": self.scale_, "components": self.components_,
                "variances": self.variances_, "t2_limit": self.t2_limit_,
                "q_limit": self.q_limit_, "t2_fit_limit": self.t2_fit_limit_,
                "q_fit_limit": self.q_fit_limit_, "reference": self.reference_}

    @classmethod
    def from_dict(cls, d: dict) -> FeatureDomain:
        """The domain :meth:`to_dict` wrote; raises ValueError/KeyError/TypeError for a
        dict of another shape (turned into one model-file error by the reader)."""
        dom = cls(variance=float(d["variance"]), margin=float(d["margin"]))
        dom.mean_ = np.asarray(d["mean"], dtype=float)
        dom.scale_ = np.asarray(d["scale"], dtype=float)
        dom.components_ = np.asarray(d["components"], dtype=float)
        dom.variances_ = np.asarray(d["variances"], dtype=float)
        dom.t2_limit_, dom.q_limit_ = float(d["t2_limit"]), float(d["q_limit"])
        # a domain saved before adaptive intervals: its limits serve (only for difficulty)
        dom.t2_fit_limit_ = float(d.get("t2_fit_limit", dom.t2_limit_))
        dom.q_fit_limit_ = float(d.get("q_fit_limit", dom.q_limit_))
        dom.reference_ = float(d.get("reference", 1.0))  # saved before it: absolute
        f = dom.mean_.shape
        if (dom.mean_.ndim != 1 or dom.scale_.shape != f or dom.components_.ndim != 2
                or dom.components_.shape[1] != f[0]
                or dom.variances_.shape != (dom.components_.shape[0],)):
            raise ValueError("the feature domain's arrays do not agree in shape")
        return dom
