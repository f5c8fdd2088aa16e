"""Annual solar irradiance on the glazing, by Radiance (the ``pyradiance`` wheel's programs).

- :mod:`~torsal.light.annual.weather`: the weather year (an EPW, TMY3 or TMY2 file, or pvlib's
  clear sky);
- :mod:`~torsal.light.annual.sky`: its sky matrix (``gendaymtx``), its suns and its seasons;
- :mod:`~torsal.light.annual.irradiance`: the irradiance on the glazing, bare or behind fins
  (``rcontrib``), in kWh/m^2 by source, month and season, and the shading factor;
- :mod:`~torsal.light.annual.daylight`: a room's sDA and ASE (IES LM-83) behind the glazing;
- :mod:`~torsal.light.annual.radiance`: finding and running the Radiance programs.

Examples
--------
>>> import numpy as np
>>> w = clear_sky_year(48.21, 16.37, timezone="Europe/Vienna")      # doctest: +SKIP
>>> sky = sky_year(w)                                               # doctest: +SKIP
>>> wall = annual_irradiance([[0, 0, 1]], [[0, -1, 0]], sky, seasons(w))   # doctest: +SKIP
>>> round(wall.annual)                                              # doctest: +SKIP
1020
"""
from torsal.core.lazy import lazy_exports
from .daylight import Blinds, Daylight, Room, blinds_closed, daylight
__getattr__, __dir__ = lazy_exports(__name__, {
    ".irradiance": ("AMBIENT_BOUNCES", "AMBIENT_DIVISIONS", "FIN_REFLECTANCE",
                    "SHADING_FACTOR_STANDARD", "AnnualIrradiance", "RadianceSettings",
                    "ShadingFactor", "Source", "annual_irradiance", "shading_factor"),
    ".radiance": ("Radiance", "RadianceError", "RadianceNotFound"),
    ".sky": ("BALANCE_TEMPERATURE_C", "GROUND_REFLECTANCE", "SeasonRule", "Seasons",
             "SkyQuantity", "SkySubdivision", "SkyYear", "seasons", "sky_year"),
    ".weather": ("Weather", "WeatherSource", "clear_sky_year", "epw_year", "weather_year"),
})

__all__ = [
    "AnnualIrradiance", "RadianceSettings", "ShadingFactor", "Source", "annual_irradiance",
    "shading_factor", "Radiance", "RadianceError", "RadianceNotFound", "SeasonRule", "Seasons",
    "SkySubdivision", "SkyQuantity", "SkyYear", "seasons", "sky_year", "Weather", "WeatherSource",
    "clear_sky_year", "epw_year", "weather_year", "AMBIENT_BOUNCES", "AMBIENT_DIVISIONS",
    "FIN_REFLECTANCE",
    "GROUND_REFLECTANCE", "BALANCE_TEMPERATURE_C", "SHADING_FACTOR_STANDARD", "Room",
    "Daylight", "daylight", "Blinds", "blinds_closed",
]
