"""SOURCE FIELD angle_x angle_y

Collimated rays from the preceding GRID, tilted from the grid's +axis by field angles: the direction is
normalize(tan(angle_x), tan(angle_y), 1) in the grid's local frame.

| parameter | unit | meaning |
|---|---|---|
| angle_x angle_y | angle (bare: deg) | field angles along local x and y; a unit after the pair applies to both |
"""
from ...lang.spec import Form, Vs
from ...lang.units import ANGLE

KIND = "SOURCE FIELD"
ROLE = "direction"
# one list of two, so that a trailing unit applies to both (`SOURCE FIELD 0.05 0.02 mrad`)
FORM = Form((Vs("angles", ANGLE, n=2, check=lambda a: None if abs(a) < 1.57 else "must be within +-90 deg"),))
EXAMPLE = "GRID DISK Z -100 150 RAYS 1000\nSOURCE FIELD 0.05 0.02 deg"


def build(b, ctx) -> dict:
    ax, ay = b["angles"]
    return {"angle_x": ax, "angle_y": ay}
