"""SOURCE POSITION x y z [CONVERGE]

Gives each ray of the preceding GRID the direction from the point (x, y, z) through its start point:
the rays diverge from the point.  With CONVERGE they run from their start point toward it instead.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | the point |
| CONVERGE | flag | rays converge to the point instead of diverging from it |
"""
from ...lang.spec import Clause, Form, Vs
from ...core.units import LENGTH

KIND = "SOURCE POSITION"
ROLE = "direction"
FORM = Form((Vs("point", LENGTH, n=3),), (Clause("CONVERGE", (), doc="converge to the point"),))
EXAMPLE = "GRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE POSITION 0 0 500 CONVERGE"


def build(b, ctx) -> dict:
    return {"point": tuple(b["point"]), "converge": bool(b.get("converge", False))}
