"""The Sun's position and the Earth's rotation, from date and time (no external data).

* Sun: the low-precision solar coordinates of Meeus, *Astronomical Algorithms* (2nd ed., ch. 25): apparent
  right ascension and declination of date to about 0.01 deg, and the Sun-Earth distance to about 1e-5 AU, for
  years 1800-2200 (outside that range the series is not meant to be used: `SunPosition` refuses it).
* Earth rotation: Greenwich mean sidereal time (IAU 1982, Meeus eq. 12.4) plus the equation of the
  equinoxes' main nutation term gives the apparent sidereal time; the sub-solar point is then
  (latitude = declination, longitude = right ascension - sidereal time).

Frames: "equatorial of date" (x to the equinox, z to the celestial pole) and Earth-fixed (x to longitude 0,
z to the north pole); the second is the first rotated by the sidereal angle about z.
"""
from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass

AU_M = 1.495978707e11
J2000 = 2451545.0
YEAR_MIN, YEAR_MAX = 1800, 2200


def julian_date(t: _dt.datetime) -> float:
    """Julian date of a UTC datetime (naive datetimes are taken as UTC)."""
    if t.tzinfo is not None:
        t = t.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    y, m = t.year, t.month
    d = t.day + (t.hour + (t.minute + (t.second + t.microsecond * 1e-6) / 60.0) / 60.0) / 24.0
    if m <= 2:
        y -= 1
        m += 12
    a = y // 100
    b = 2 - a + a // 4
    return math.floor(365.25 * (y + 4716)) + math.floor(30.6001 * (m + 1)) + d + b - 1524.5


@dataclass(frozen=True)
class SunPosition:
    ra_deg: float               # apparent right ascension, of date
    dec_deg: float              # apparent declination, of date
    distance_au: float
    gast_deg: float             # Greenwich apparent sidereal time

    @property
    def subsolar_lat_deg(self) -> float:
        return self.dec_deg

    @property
    def subsolar_lon_deg(self) -> float:
        return (self.ra_deg - self.gast_deg + 180.0) % 360.0 - 180.0

    def earth_fixed_vector_m(self) -> tuple:
        """The Sun's position in the Earth-fixed frame, metres."""
        r = self.distance_au * AU_M
        la, lo = math.radians(self.subsolar_lat_deg), math.radians(self.subsolar_lon_deg)
        return (r * math.cos(la) * math.cos(lo), r * math.cos(la) * math.sin(lo), r * math.sin(la))


def sun_position(t: _dt.datetime) -> SunPosition:
    if not YEAR_MIN <= t.year <= YEAR_MAX:
        raise ValueError(f"{t:%Y-%m-%d} is outside the solar ephemeris' range ({YEAR_MIN}-{YEAR_MAX})")
    jd = julian_date(t)
    T = (jd - J2000) / 36525.0
    L0 = 280.46646 + 36000.76983 * T + 0.0003032 * T * T
    M = math.radians(357.52911 + 35999.05029 * T - 0.0001537 * T * T)
    e = 0.016708634 - 0.000042037 * T - 0.0000001267 * T * T
    C = ((1.914602 - 0.004817 * T - 0.000014 * T * T) * math.sin(M) + (0.019993 - 0.000101 * T) * math.sin(2 * M)
         + 0.000289 * math.sin(3 * M))
    true_lon = L0 + C
    nu = M + math.radians(C)
    R = 1.000001018 * (1 - e * e) / (1 + e * math.cos(nu))
    omega = math.radians(125.04 - 1934.136 * T)
    lam = math.radians(true_lon - 0.00569 - 0.00478 * math.sin(omega))
    eps0 = 23.0 + (26.0 + (21.448 - T * (46.8150 + T * (0.00059 - T * 0.001813))) / 60.0) / 60.0
    eps = math.radians(eps0 + 0.00256 * math.cos(omega))
    ra = math.degrees(math.atan2(math.cos(eps) * math.sin(lam), math.cos(lam))) % 360.0
    dec = math.degrees(math.asin(math.sin(eps) * math.sin(lam)))
    return SunPosition(ra, dec, R, apparent_sidereal_time_deg(jd, T, omega, eps))


def gmst_deg(jd: float) -> float:
    """Greenwich mean sidereal time (IAU 1982; Meeus eq. 12.4), degrees in [0, 360)."""
    T = (jd - J2000) / 36525.0
    g = 280.46061837 + 360.98564736629 * (jd - J2000) + 0.000387933 * T * T - T ** 3 / 38710000.0
    return g % 360.0


def apparent_sidereal_time_deg(jd: float, T: float, omega: float, eps: float) -> float:
    """GMST plus the equation of the equinoxes (main nutation term, -17.20" sin Omega in longitude)."""
    dpsi = math.radians(-17.20 / 3600.0) * math.sin(omega)
    return (gmst_deg(jd) + math.degrees(dpsi * math.cos(eps))) % 360.0
