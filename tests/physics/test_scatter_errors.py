"""Bad scattering input gets a clear diagnostic from `irt check` (file:line:col, message, exit code 2), never a
wrong run: maps of the wrong shape, class maps with classes no model covers, fraction maps outside [0, 1],
transmitting models on opaque objects (whatever the order of INTERFACE and SCATTER, and through SCATTER MAP),
OPAQUE WHERE on an object that is not clear where it is absent, or with an empty range,
single-scattering albedos outside [0, 1], negative optical depths and extinctions.

`irt check` runs in-process (irtlang.cli.main, the same code as the command) to keep the fast tier fast.
"""
import numpy as np
import pytest

from irtlang import cli

HEAD = "UNITS KM\nWAVELENGTHS 550 NM\n"
EARTH_TRACE = "GRID RECT X 20000 -7000 7000 -7000 7000 10 10 RANDOM\nSOURCE DIRECTION -1 0 0\nTRACE\n"


def irt_check(tmp_path, monkeypatch, capsys, text: str):
    monkeypatch.chdir(tmp_path)
    np.save(tmp_path / "bad_shape.npy", np.zeros((3, 5)))                                 # 5 != 2 x 3
    np.save(tmp_path / "flat.npy", np.zeros(8))                                           # not 2-D
    np.save(tmp_path / "three.npy", np.array([[0, 1, 2, 0], [1, 1, 2, 2]], np.int32))      # classes 0, 1, 2
    np.save(tmp_path / "frac.npy", np.full((2, 4), 1.7))
    (tmp_path / "s.inr").write_text(text)
    rc = cli.main(["check", "s.inr"])
    err = capsys.readouterr().err
    return rc, err


CASES = [
    ("map-shape",
     HEAD + "MODEL grey LAMBERTIAN 0.5\nMAP m LATLON 'bad_shape.npy'\n",
     "s.inr:4:14: error: map 'bad_shape.npy' has shape (3, 5): a global LATLON grid has twice as many columns "
     "(longitude, 360 deg) as rows (latitude, 180 deg)"),
    ("map-not-2d",
     HEAD + "MAP m LATLON 'flat.npy'\n",
     "s.inr:3:14: error: map 'flat.npy' has shape (8,); a LATLON map is 2-D (lat rows, lon columns)"),
    ("classes-without-model",
     HEAD + "MODEL dark LAMBERTIAN 0.1\nMODEL white LAMBERTIAN 0.9\nMAP cover LATLON 'three.npy'\n"
     "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n  SCATTER MAP cover MODELS dark white\n" + EARTH_TRACE,
     "s.inr:10:3: error: map cover has 3 classes but MODELS names 2"),
    ("fraction-out-of-range",
     HEAD + "MODEL grey LAMBERTIAN 0.5\nMAP snow LATLON 'frac.npy'\n"
     "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n  SCATTER MAP snow MODELS grey\n" + EARTH_TRACE,
     "s.inr:9:3: error: map snow is used as a fraction map (one model) but holds values outside [0, 1] (1.7 .. 1.7)"),
    ("transmitting-on-absorb",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nSURFACE\n  PLANE Z 0 DISK 10\nOBJECT plate\n"
     "  INTERFACE ABSORB\n  SCATTER MODEL leaf\n",
     "s.inr:8:17: error: model leaf transmits, but object plate is opaque (INTERFACE ABSORB)"),
    ("transmitting-on-reflect",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nSURFACE\n  PLANE Z 0 DISK 10\nOBJECT plate\n"
     "  INTERFACE REFLECT\n  SCATTER MODEL leaf\n",
     "s.inr:8:17: error: model leaf transmits, but object plate is opaque (INTERFACE REFLECT)"),
    ("transmitting-interface-after-scatter",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nSURFACE\n  PLANE Z 0 DISK 10\nOBJECT plate\n"
     "  SCATTER MODEL leaf\n  INTERFACE ABSORB\nGRID RECT Z 5 -1 1 -1 1 2 2\nSOURCE DIRECTION 0 0 -1\nTRACE\n",
     "s.inr:7:3: error: model leaf transmits, but object plate is opaque (INTERFACE ABSORB)"),
    ("transmitting-no-interface",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nSURFACE\n  PLANE Z 0 DISK 10\nOBJECT plate\n"
     "  SCATTER MODEL leaf\nGRID RECT Z 5 -1 1 -1 1 2 2\nSOURCE DIRECTION 0 0 -1\nTRACE\n",
     "s.inr:7:3: error: model leaf transmits, but object plate is opaque (INTERFACE ABSORB, the default)"),
    ("transmitting-through-a-map",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nMODEL white LAMBERTIAN 0.9\nMAP cover LATLON 'three.npy'\n"
     "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n  SCATTER MAP cover MODELS leaf white white\n"
     + EARTH_TRACE,
     "s.inr:10:3: error: model leaf transmits, but object earth is opaque (INTERFACE ABSORB)"),
    ("opaque-where-on-an-absorbing-object",
     HEAD + "MAP m LATLON 'frac.npy'\nSURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n"
     "  OPAQUE WHERE m FROM 0.5 TO 1\n",
     "s.inr:8:3: error: OPAQUE WHERE needs object earth to be clear where it is absent: give it INTERFACE TRANSMIT "
     "with one medium on both sides first"),
    ("opaque-where-then-an-absorbing-interface",
     HEAD + "MAP m LATLON 'frac.npy'\nSURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE TRANSMIT AIR AIR\n"
     "  OPAQUE WHERE m FROM 0.5 TO 1\n  INTERFACE ABSORB\n",
     "s.inr:9:3: error: object earth has OPAQUE WHERE: its INTERFACE must stay TRANSMIT with one medium on both "
     "sides (clear where it is absent)"),
    ("opaque-where-empty-range",
     HEAD + "MAP m LATLON 'frac.npy'\nSURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE TRANSMIT AIR AIR\n"
     "  OPAQUE WHERE m FROM 1 TO 0.5\n",
     "s.inr:8:28: error: OPAQUE WHERE ... FROM lo TO hi needs lo < hi, got 1 and 0.5"),
    ("opaque-where-twice",
     HEAD + "MAP m LATLON 'frac.npy'\nSURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE TRANSMIT AIR AIR\n"
     "  OPAQUE WHERE m FROM 0.5 TO 1\n  OPAQUE WHERE m FROM 0.5 TO 1\n",
     "s.inr:9:3: error: object earth already has an OPAQUE WHERE"),
    ("transmitting-on-opaque-where",
     HEAD + "MODEL leaf LAMBERTIAN 0.5 TRANSMIT 0.2\nMAP m LATLON 'frac.npy'\nSURFACE\n  SPHERE 0 0 0 6371\n"
     "OBJECT earth\n  INTERFACE TRANSMIT AIR AIR\n  OPAQUE WHERE m FROM 0.5 TO 1\n  SCATTER MODEL leaf\n" + EARTH_TRACE,
     "s.inr:10:3: error: model leaf transmits, but object earth is opaque (OPAQUE WHERE, where it is present)"),
    ("albedo-above-1",
     HEAD + "MEDIUM layer INDEX 1 VOLUME EXTINCTION 0.1 ALBEDO 1.5 PHASE RAYLEIGH\n",
     "s.inr:3:51: error: MEDIUM INDEX ALBEDO: albedo must be in [0, 1], got 1.5"),
    ("albedo-negative",
     HEAD + "MEDIUM layer INDEX 1 VOLUME EXTINCTION 0.1 ALBEDO -0.2\n",
     "s.inr:3:51: error: MEDIUM INDEX ALBEDO: albedo must be in [0, 1], got -0.2"),
    ("slab-albedo-above-1",
     HEAD + "MODEL air RAYLEIGH TAU 0.1 ALBEDO 1.01\n",
     "s.inr:3:35: error: MODEL RAYLEIGH ALBEDO: albedo must be in [0, 1], got 1.01"),
    ("negative-tau-rayleigh",
     HEAD + "MODEL air RAYLEIGH TAU -0.1 ALBEDO 1\n",
     "s.inr:3:24: error: MODEL RAYLEIGH TAU: tau must be >= 0, got -0.1"),
    ("negative-tau-hg",
     HEAD + "MODEL cloud HG G 0.85 TAU -0.1 ALBEDO 0.99\n",
     "s.inr:3:27: error: MODEL HG TAU: tau must be >= 0, got -0.1"),
    ("negative-extinction",
     HEAD + "MEDIUM layer INDEX 1 VOLUME EXTINCTION -0.001\n",
     "s.inr:3:40: error: MEDIUM INDEX EXTINCTION: extinction must be >= 0, got -0.001"),
]


@pytest.mark.parametrize("name,text,first", CASES, ids=[c[0] for c in CASES])
def test_bad_scatter_input_is_diagnosed(tmp_path, monkeypatch, capsys, name, text, first):
    rc, err = irt_check(tmp_path, monkeypatch, capsys, text)
    assert rc == cli.EXIT_INPUT, err
    assert err.splitlines()[0] == first, err
    assert err.rstrip().endswith("1 error")
    assert "Traceback" not in err
