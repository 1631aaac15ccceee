"""The Earth system model: its physics and its data tiers (docs/earth.md).

ephemeris (Sun, sidereal time), atmosphere (USSA 1976, Rayleigh, refractivity), gas (O3/H2O/O2, SPCTRAL2),
clouds (Hu & Stamnes form, Fu 1996), aerosols (OPAC types), surfaces (IGBP Ross-Li, snow, sea ice, ocean),
data (the default tier of global grids), products (the real tier: MODIS, AMSR-E, MERRA-2 loaders),
latlon (the LATLON grid convention), models (the Earth as MODEL lines and include files).
"""
