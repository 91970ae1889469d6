"""What the virtual camera is: :class:`SensorSpec`, its presets and its ``--sensor`` text.

T2Cam (thesis §2.2) is a stereo camera pair inside the rim that sees a point cloud of
about 200 mm (meridional) x 280 mm (a 40° arc) around the contact patch. Its points are
where digital image correlation (DIC) finds them, not the FE nodes; their positions carry
errors (about 2 mm in the 2017 T2Cam paper); strain comes from four constant-strain
triangles (CST) around each point of the noisy cloud against a noisy reference cloud of
the inflated, unloaded tyre (a 0.5 % strain band in the 2020 paper).

A :class:`SensorSpec` is a frozen, JSON-serialisable value (:meth:`SensorSpec.to_dict`,
:meth:`SensorSpec.from_dict`); :func:`sensor_spec` parses the command line's
``PRESET[,field=value...]``.

The ``t2cam-2020`` preset's position noise
------------------------------------------
For a CST with edge length ``h`` and i.i.d. position noise ``sigma`` per coordinate in
both the reference and the deformed cloud, the strain noise is about
``std = sigma * sqrt(2) * c / h``: a point's displacement (deformed minus reference
position) has std ``sigma * sqrt(2)`` per coordinate, and ``c`` is what the strain of
the four triangles, averaged, makes of it.
On a square grid the four triangles around an interior point average to the central
difference ``(u_E - u_W) / (2 h)``, whose std is ``sqrt(4 sigma**2) / (2 h) = sigma / h``,
so ``c = 1 / sqrt(2)``. Measured with this implementation (2000 noise draws, interior
points on the crown; tests/analysis/camera/sensor/test_sensor_noise.py checks it):
``c = 0.708`` (xx), ``0.706`` (yy), ``0.50`` (xy, the tensor shear). On the window's
edge columns and rows only two triangles remain, a one-sided difference: there the
normal component's std doubles (``c = sqrt(2)``).

We read the 2020 paper's "0.5 % strain band" as the width of the band of +-1 standard
deviation, i.e. ``band = 2 std`` and ``std = 0.25 %`` (= 2.5e-3). With ``h`` = 10 mm
(the preset's spacing): ``sigma = std * h / (sqrt(2) * c) = 2.5e-3 * 10 mm = 0.025 mm``.
That is DIC's sub-pixel matching noise, not the 2017 paper's 2 mm, which is an absolute
(largely systematic) position error of the whole cloud.
"""

from __future__ import annotations

import math
import numbers
import types
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from analysis.errors import ParameterError

__all__ = ["NOISE_FIELDS", "PRESETS", "T2CAM_2020_NOISE_MM", "SensorSpec", "sensor_spec"]

#: the fields that make a measurement noisy (zero in :meth:`SensorSpec.noise_free`)
NOISE_FIELDS = ("noise_mm", "correlated_mm", "rotation_deg", "scale", "drop_fraction")
_OPTIONAL = ("width_mm", "spacing_mm")  # None allowed
_FLOATS = ("window_deg", "width_mm", "spacing_mm", "noise_mm", "correlated_mm",
           "correlation_mm", "rotation_deg", "scale", "drop_fraction", "centre_deg",
           "centre_mm")

#: CST strain std 0.25 % (the 2020 paper's 0.5 % band read as +-1 std) on a 10 mm grid:
#: sigma = 2.5e-3 * 10 mm / (sqrt(2) * c) with c = 1/sqrt(2) (module docstring).
T2CAM_2020_NOISE_MM = 0.025


@dataclass(frozen=True)
class SensorSpec:
    """A virtual T2Cam (thesis §2.2): its window, its points and its errors.

    Parameters
    ----------
    name : str
        A label for reports (a preset's name, or the ``--sensor`` text).
    window_deg : float
        Circumferential extent in degrees, centred on the contact centre (angle 0, under
        the wheel centre); 0 < window_deg <= 360. T2Cam: 40° (about 280 mm of arc).
    width_mm : float or None
        Meridional extent along the inner surface in mm, centred on the crown (y = 0);
        None: the whole meridian. T2Cam: about 200 mm.
    spacing_mm : float or None
        Spacing of the point grid in mm: circumferential arc length at the crown's inner
        radius, and meridional arc length. None: the FE nodes inside the window (the
        ideal sensor: no interpolation).
    noise_mm : float
        Std (mm) of i.i.d. Gaussian position noise per coordinate, in every cloud (the
        reference cloud and each deformed cloud).
    correlated_mm, correlation_mm : float
        Std (mm) of spatially correlated Gaussian position noise per coordinate, and the
        length (mm) of its squared-exponential kernel over the distance of two points.
    rotation_deg, scale : float
        Stereo calibration error: each measured cloud is rotated rigidly about its
        centroid by an angle ~ N(0, rotation_deg) (degrees) about a random axis, and
        scaled by 1 + N(0, scale).
    drop_fraction : float
        Share of the points that the image correlation misses in each cloud
        (0 <= drop_fraction < 0.5); they are filled from their neighbours in the features.
    centre_deg, centre_mm : float
        Where the window looks (issue 46: where to look): its centre's angle from the
        contact centre, degrees in [-180, 180], positive towards +x (ahead of the patch
        for the farm's rolls, whose wheel travels along +x: docs/rolling.md), and its
        centre's meridional arc length from the crown, mm, positive towards +y (a
        shoulder, a sidewall). 0, 0: centred on the patch and the crown, as T2Cam looks.
    """

    name: str = "custom"
    window_deg: float = 40.0
    width_mm: float | None = 200.0
    spacing_mm: float | None = 10.0
    noise_mm: float = 0.0
    correlated_mm: float = 0.0
    correlation_mm: float = 50.0
    rotation_deg: float = 0.0
    scale: float = 0.0
    drop_fraction: float = 0.0
    centre_deg: float = 0.0
    centre_mm: float = 0.0

    def __post_init__(self) -> None:
        for key in _FLOATS:  # ints, numpy numbers become floats: one value, one type
            value = getattr(self, key)
            if isinstance(value, numbers.Real) and not isinstance(value, bool):
                object.__setattr__(self, key, float(value))
        self.validate()

    def validate(self) -> None:
        """Raise :class:`ParameterError` (one line) for the first bad field."""
        if not isinstance(self.name, str) or not self.name.strip():
            raise ParameterError(f"sensor name must be a non-empty string, got {self.name!r}")
        for key in _FLOATS:
            value = getattr(self, key)
            if value is None and key in _OPTIONAL:
                continue
            if not isinstance(value, float) or not math.isfinite(value):
                none = " or None" if key in _OPTIONAL else ""
                raise ParameterError(f"sensor field {key} must be a finite number{none}, "
                                     f"got {value!r}")
        if not 0.0 < self.window_deg <= 360.0:
            raise ParameterError(f"sensor window_deg must be in (0, 360] degrees, got "
                                 f"{self.window_deg:g}")
        for key in _OPTIONAL:
            value = getattr(self, key)
            if value is not None and value <= 0.0:
                raise ParameterError(f"sensor {key} must be positive (mm) or None, got "
                                     f"{value:g}")
        for key in ("noise_mm", "correlated_mm", "rotation_deg", "scale"):
            if getattr(self, key) < 0.0:
                raise ParameterError(f"sensor {key} must be at least 0 (a standard "
                                     f"deviation), got {getattr(self, key):g}")
        if self.correlation_mm <= 0.0:
            raise ParameterError(f"sensor correlation_mm must be positive (a kernel length "
                                 f"in mm), got {self.correlation_mm:g}")
        if not -180.0 <= self.centre_deg <= 180.0:
            raise ParameterError(f"sensor centre_deg must be in [-180, 180] degrees, got "
                                 f"{self.centre_deg:g}")
        if not 0.0 <= self.drop_fraction < 0.5:
            raise ParameterError(f"sensor drop_fraction must be in [0, 0.5), got "
                                 f"{self.drop_fraction:g}")

    def to_dict(self) -> dict[str, Any]:
        """Every field by name (JSON-serialisable: str, float, None)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SensorSpec:
        """The spec of :meth:`to_dict`'s output; missing fields take their defaults.

        Raises
        ------
        ParameterError
            For a key that is no field (naming the fields), or a bad value.
        """
        unknown = sorted(set(d) - set(FIELDS))
        if unknown:
            raise ParameterError(f"unknown sensor field(s) {', '.join(unknown)}; the fields "
                                 f"are {', '.join(FIELDS)}")
        return cls(**dict(d))

    def noise_free(self) -> SensorSpec:
        """This sensor without its errors: every field of :data:`NOISE_FIELDS` zero, the
        rest (name included) unchanged, so ``spec.noise_free() == spec`` iff it has none."""
        return replace(self, noise_mm=0.0, correlated_mm=0.0, rotation_deg=0.0, scale=0.0,
                       drop_fraction=0.0)

    @property
    def noisy(self) -> bool:
        """Whether any field of :data:`NOISE_FIELDS` is non-zero."""
        return any(getattr(self, name) != 0 for name in NOISE_FIELDS)

    @property
    def is_ideal(self) -> bool:
        """Whether it reads every inner node exactly (``ideal-full``: today's analyses):
        a 360° window, the whole meridian, points at the FE nodes and no noise."""
        return (self.window_deg == 360.0 and self.width_mm is None
                and self.spacing_mm is None and not self.noisy)


FIELDS = tuple(f.name for f in fields(SensorSpec))

PRESETS: Mapping[str, SensorSpec] = types.MappingProxyType({
    # 2017 T2Cam paper: a 40° x 200 mm cloud, position errors of about 2 mm
    "t2cam-2017": SensorSpec("t2cam-2017", 40.0, 200.0, 10.0, noise_mm=2.0),
    # 2020 paper: the same cloud, CST strain within a 0.5 % band (module docstring)
    "t2cam-2020": SensorSpec("t2cam-2020", 40.0, 200.0, 10.0, noise_mm=T2CAM_2020_NOISE_MM),
    # every inner node exactly: what the analyses read without a sensor
    "ideal-full": SensorSpec("ideal-full", 360.0, None, None),
})


def sensor_spec(text: str) -> SensorSpec:
    """Parse ``PRESET[,field=value...]`` or ``field=value[,field=value...]``.

    ``"t2cam-2017"``, ``"t2cam-2017,window_deg=90,noise_mm=0.5"``, or
    ``"window_deg=20,spacing_mm=5"`` (changes to :class:`SensorSpec`'s defaults).
    ``none`` sets ``width_mm`` or ``spacing_mm`` to None. A spec with changes is named
    by the text (``name=...`` overrides).

    Raises
    ------
    ParameterError
        One line naming the presets or the fields.
    """
    parts = [p.strip() for p in str(text).split(",")]
    if not parts or not parts[0]:
        raise ParameterError(f"empty sensor {text!r}: give a preset ({', '.join(PRESETS)}) "
                             "and/or field=value changes")
    base = SensorSpec()
    if "=" not in parts[0]:
        if parts[0] not in PRESETS:
            raise ParameterError(f"unknown sensor preset {parts[0]!r}; the presets are "
                                 f"{', '.join(PRESETS)} (then optionally ,field=value)")
        base = PRESETS[parts[0]]
        parts = parts[1:]
    changes: dict[str, Any] = {}
    for part in parts:
        key, eq, value = (s.strip() for s in part.partition("="))
        if not eq or not key:
            raise ParameterError(f"bad sensor change {part!r} in {text!r}: write field=value "
                                 f"with a field of {', '.join(FIELDS)}")
        if key not in FIELDS:
            raise ParameterError(f"unknown sensor field {key!r} in {text!r}; the fields are "
                                 f"{', '.join(FIELDS)}")
        changes[key] = _value(key, value, text)
    if not changes:
        return base
    changes.setdefault("name", ",".join(s.strip() for s in str(text).split(",")))
    return replace(base, **changes)


def _value(key: str, value: str, text: str) -> Any:
    if key == "name":
        return value
    if key in _OPTIONAL and value.lower() in ("none", "null", ""):
        return None
    try:
        return float(value)
    except ValueError:
        none = " or none" if key in _OPTIONAL else ""
        raise ParameterError(f"sensor field {key} must be a number{none}, got {value!r} in "
                             f"{text!r}") from None
