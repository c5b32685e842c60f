"""Local tangent-plane <-> latitude/longitude, as MOOS's CMOOSGeodesy "local grid".

Method (CMOOSGeodesy::LocalGrid2LatLong / LatLong2LocalGrid, MOOS v10 and MOOS-IvP
``lib_geometry``; documented there as valid for grids smaller than ~300 km): a sphere
whose radius is the WGS-84 ellipsoid's geocentric radius at the origin latitude,

    R = b * sqrt(1 + tan^2(lat0)) / sqrt(b^2/a^2 + tan^2(lat0)),
    a = 6378137 m, b = 6356752 m (the constants MOOS uses),

    lat = lat0 + asin(north / R),            lon = lon0 + asin(east / (R cos lat0))
    north = R sin(lat - lat0),               east = R sin(lon - lon0) cos(lat)

(degrees in the API, radians in the trigonometry). The forward and inverse formulas are
MOOS's own and are *not* exact inverses of each other away from the origin (the inverse
uses cos(lat), the forward cos(lat0)); the east round-trip error is about
x*y*tan(lat0)/R: 1.4 mm at (100 m, 100 m), 0.14 m at (1 km, 1 km) at 42 deg N (tested).
We reproduce MOOS, not a better projection, so that our NAV_LAT/NAV_LONG agree with what
a MOOS process computing from the same LatOrigin/LongOrigin would post. MOOS-IvP builds
that define ``USE_UTM`` convert through UTM instead.

x_east / y_north are MOOS local metres (docs/conventions.md: MOOS x east, y north).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["latlon_from_local", "local_from_latlon", "moos_grid_radius"]

_A = 6378137.0  # semi-major axis used by CMOOSGeodesy, m
_B = 6356752.0  # semi-minor axis used by CMOOSGeodesy, m


def moos_grid_radius(lat0_deg: float) -> float:
    """Radius (m) of CMOOSGeodesy's local-grid sphere at origin latitude ``lat0_deg``."""
    t2 = math.tan(math.radians(lat0_deg)) ** 2
    return _B * math.sqrt(1.0 + t2) / math.sqrt(_B**2 / _A**2 + t2)


def latlon_from_local(
    x_east: ArrayLike, y_north: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float]:
    """(lat, lon) in degrees of MOOS local (x east, y north) metres, LocalGrid2LatLong."""
    r = moos_grid_radius(lat0_deg)
    if isinstance(x_east, float | int) and isinstance(y_north, float | int):  # scalar fast path
        return (lat0_deg + math.degrees(math.asin(y_north / r)),
                lon0_deg + math.degrees(math.asin(x_east / (r * math.cos(math.radians(lat0_deg))))))
    lat = lat0_deg + np.degrees(np.arcsin(np.asarray(y_north, dtype=float) / r))
    lon = lon0_deg + np.degrees(
        np.arcsin(np.asarray(x_east, dtype=float) / (r * math.cos(math.radians(lat0_deg)))))
    if np.ndim(lat) == 0:
        return float(lat), float(lon)
    return lat, lon


def local_from_latlon(
    lat_deg: ArrayLike, lon_deg: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float]:
    """MOOS local (x east, y north) metres of (lat, lon) degrees, LatLong2LocalGrid."""
    r = moos_grid_radius(lat0_deg)
    lat = np.asarray(lat_deg, dtype=float)
    x = r * np.sin(np.radians(np.asarray(lon_deg, dtype=float) - lon0_deg)) * np.cos(
        np.radians(lat))
    y = r * np.sin(np.radians(lat - lat0_deg))
    if np.ndim(x) == 0:
        return float(x), float(y)
    return x, y
