"""Camera-side (adjoint) imaging: the scene a `TRACE CAMERA` traces, built from the script's own scene.

A forward trace sends light from the emitter and lets the detector catch it; for an image of an extended scene
through a small pupil that wastes almost every ray (each Sun ray lights about one pixel).  A camera trace runs
the other way, as renderers do (docs/tracer.md, "Camera-side images"):

* rays start on the camera detector's pixels, ``s x s`` stratified points per pixel (one random point in each
  sub-cell) and per traced line, Lambertian toward the AIM object (the instrument's first element seen from the
  focal plane), so they go backward through the instrument's own objects and out through its pupil;
* with ``DIRECTIONS m`` each point sends 2 m^2 rays instead of one: a pair in each of m x m strata of equal
  solid angle of the aim cone (m bands in the cosine of the angle from the cone's axis by m in azimuth).  The
  strata take the spread between directions out of the estimate; its variance comes from the pairs: the sum
  over strata of (a - b)^2 is an unbiased estimate of the variance of the stratified total (a and b are
  independent draws in one stratum), which the per-ray spread would overstate.  A one-pixel camera at an
  entrance pupil, aimed at a planet, so gives the disk-integrated spectrum (``SPECTRUM OF`` the camera);
* spectral sampling: with ``SPECTRAL k`` each of the s x s points carries k rays whose lines are drawn from the
  images' weights (light radiance x filter x QE, each image an equal share), stratified over their cumulative
  distribution, each weighted by 1 / (k pmf); without it every line the detector sees gets its own rays.  An
  even k (without DIRECTIONS) is paired: k / 2 strata of the cumulative weight with two independent rays each
  (independent points in the same sub-cell, lines in the same stratum, their own directions), so the pixels'
  variances come from the pairs' differences, per filter image (``spectral_paired``);
* every scattering event sends one next-event ray toward the light (the one ``EMITTING SPHERE`` of the trace),
  whatever the script's ``TOWARD`` targets were, then the path goes on by sampling the scatter model, with
  Russian roulette (multiple scattering);
* the light becomes an absorbing sphere whose ``DETECTOR ... START`` bins what reaches it by the camera pixel
  the path started from: that is the camera's image, with the camera detector's QE and FILTERS.

Normalization (reciprocity): the power on a pixel of area A is P = int_A int L_in cos(t) dw dA.  A camera ray
starts uniformly in a pixel sub-cell and leaves in the cone of the AIM object's bounding sphere (solid angle
O, uniform), so one ray estimates A O cos(t) L_in; the kernel's Lambertian emitter gives it the weight
w0 cos(t) O / pi, and the next-event ray toward a light of radiance L_s carries f cos(s) O_s, so with
w0 = pi A L_s / s^2 (per ray of the s^2 in a pixel) the light's START image is the pixel power in W.  A
Lambertian sphere of power P per line (FLUX, as the forward trace emits it) has radiance P / (4 pi^2 R^2).

Only the lines the detector responds to are traced (QE and, with FILTERS, any filter's transmission above 0).

Stokes images (``TRACE CAMERA ... STOKES`` under POLARIZATION): an ``analyzer`` puts ideal elements on the
detector's face, each a plane parallel to it a hair in front (on the instrument's side), as wide as the detector
and more: a linear polarizer at an angle from the detector's local x toward its y, or (circular) a polarizer at
+-45 deg and, beyond it, a quarter-wave retarder along x.  By reciprocity the camera trace's I is then what the
pixel measures behind that analyzer; the engine combines six such traces into I, Q, U and V
(irtlang/engine.py, docs/tracer.md "Polarization").
This module only builds model objects: the packing is in irtlang/compile/pack.py ("CAMERA" sources).
"""
from __future__ import annotations

import math

from ..core.diagnostics import Span, error
from . import scene as M


def spectral_paired(spectral: int, directions: int) -> bool:
    """Whether a camera's spectral samples come in pairs: ``SPECTRAL k`` with k even and no ``DIRECTIONS`` (whose
    own pairs already share a spectral stratum).  Then the k rays of a point are k / 2 strata of the images'
    cumulative weight, two independent rays in each, and a pixel's variance is the sum over its pairs of the
    squared difference, which (unlike the spread between rays) leaves out the spread between the strata."""
    return spectral >= 2 and spectral % 2 == 0 and directions == 0


def camera_scene(scene: M.Scene, params: dict, span: Span, analyzer: tuple = ()) -> tuple[M.Scene, dict]:
    """The scene of a camera trace and what the engine needs to present its image as the camera's.

    params: camera (object key), aim (object key), sub (s: s x s rays per pixel and line), spectral (k spectral
    samples per point, 0: every line), directions (m: 2 m^2 rays per point, a pair in each of m x m strata of
    the aim cone; 0: one ray, uniform in the cone), window
    ((i0, i1, j0, j1) pixel columns i0..i1-1 and rows j0..j1-1, or None for the whole detector).
    analyzer: ideal elements on the detector's face, from the detector outward: ("polarizer", angle) or
    ("retarder", angle, retardance), angles in radians from the detector's local x toward its y."""
    objs = scene.objects
    cam = objs.get(params["camera"])
    aim = objs.get(params["aim"])
    if cam is None or aim is None:      # the interpreter checked the names; CONSIDER may have dropped them
        raise error(span, f"TRACE CAMERA: object {params['camera'] if cam is None else params['aim']} is not in "
                    "the traced scene", "CONSIDER ONLY must keep the camera, its AIM object and the scene")
    det = cam.detector
    if det is None or det.start is not None:
        raise error(span, f"TRACE CAMERA {cam.name}: the camera needs a DETECTOR PIXELS grid (without START)",
                    "give the focal-plane object DETECTOR PIXELS nx ny")
    surf = cam.surfaces[0]
    if surf.kind != "PLANE" or surf.aperture is None:
        raise error(span, f"TRACE CAMERA {cam.name}: the camera's detector must be a PLANE with an aperture",
                    "SURFACE; PLANE Z z RECT hx hy; OBJECT fpa; DETECTOR PIXELS nx ny")
    lights = [s for s in scene.sources if s.kind == "EMITTING SPHERE"]
    others = [s for s in scene.sources if s.kind != "EMITTING SPHERE"]
    if len(lights) != 1 or others:
        raise error(span, f"TRACE CAMERA needs exactly one EMITTING SPHERE as its light (found {len(lights)} "
                    f"and {len(others)} other source(s))",
                    "define only the light (EMITTING SPHERE ... and its FLUX) before TRACE CAMERA")
    light = lights[0]
    ap = surf.aperture
    hx, hy = ap.params[:2] if ap.kind in ("RECT", "ELLIPSE") else (ap.params[-1], ap.params[-1])
    nx, ny = det.nx, det.ny
    # a RECT's pixels tile it; a DISK or ELLIPSE is one pixel, sampled over the ellipse itself (a grid's corner
    # pixels would lie partly outside it)
    ellipse = ap.kind in ("DISK", "ELLIPSE")
    if ap.kind == "ANNULUS" or (ellipse and nx * ny > 1):
        raise error(span, f"TRACE CAMERA {cam.name}: a camera's detector is a RECT of pixels, or one pixel on a DISK "
                    f"or ELLIPSE ({cam.name} has {ap.kind}" + (f" and {nx} x {ny} pixels)" if ellipse else ")"),
                    "give the camera's PLANE a RECT aperture, or its DETECTOR PIXELS 1")
    px, py = 2 * hx / nx, 2 * hy / ny
    i0, i1, j0, j1 = params.get("window") or (0, nx, 0, ny)
    if not (0 <= i0 < i1 <= nx and 0 <= j0 < j1 <= ny):
        raise error(span, f"TRACE CAMERA ... WINDOW {i0} {i1} {j0} {j1} is not inside the detector's "
                    f"{nx} x {ny} pixels", "WINDOW i0 i1 j0 j1: columns i0..i1-1, rows j0..j1-1, from 0")
    extent = (-hx + i0 * px, -hx + i1 * px, -hy + j0 * py, -hy + j1 * py)

    # the camera's frame (its plane's local x, y: the detector's pixel axes), in the camera's group
    frame = surf.frame.then(cam.transform.R, cam.transform.T)
    # which side the instrument lies on: the AIM object's first surface, in the same group's frame
    a_frame = aim.surfaces[0].frame.then(aim.transform.R, aim.transform.T)
    if aim.group == cam.group:
        ca, pc = a_frame.T, frame.T
    else:
        ca = scene.world_transform(M.replace(aim, transform=a_frame)).T
        pc = scene.world_transform(M.replace(cam, transform=frame)).T
    nz = (frame.R[2], frame.R[5], frame.R[8])
    side = 1.0 if sum(n * (a - b) for n, a, b in zip(nz, ca, pc)) >= 0 else -1.0
    # start a hair off the detector plane, on the instrument's side (a ray must not meet its own start plane)
    eps = 1e-9 * max(hx, hy, 1e-3)
    frame = frame.shifted(tuple(side * eps * n for n in nz))

    # the lines the camera sees
    L = scene.n_lines
    qe = det.qe or (1.0,) * L
    filters = det.filters
    if params.get("filter"):                 # TRACE CAMERA ... FILTER f: only that image, lines from its band
        only = tuple(f for f in (filters or ()) if f[0].upper() == params["filter"].upper())
        if not only:
            raise error(span, f"TRACE CAMERA ... FILTER {params['filter']}: the camera {cam.name} has no such filter",
                        "name one of the camera DETECTOR's FILTERS")
        filters = only
    if filters:
        response = tuple(tuple(float(tr[k]) * qe[k] for _, tr in filters) for k in range(L))
    else:
        response = tuple((float(qe[k]),) for k in range(L))
    mask = tuple(max(r) > 0.0 for r in response)
    spectral = int(params.get("spectral") or 0)

    lname = "CAMERA_LIGHT"
    while lname in objs:
        lname += "_"
    lp = light.params
    light_obj = M.SceneObject(
        lname, (M.Surface("SPHERE", M.frozen_params({"radius": lp["radius"]}), M.Transform(T=tuple(lp["centre"])),
                          None, light.span),),
        interface=M.Interface("absorb", None, "AIR", "AIR", light.span),
        detector=M.Detector(i1 - i0, j1 - j0, span, qe=det.qe, filters=filters, start=extent),
        group=light.group, span=light.span)
    new_objs = {}
    for k, o in objs.items():
        sc = tuple(M.replace(s, toward=lname, rays=1) for s in o.scatter)
        new_objs[k] = M.replace(o, scatter=sc, detector=None)
    new_objs[lname] = light_obj
    # the analyzer: planes parallel to the detector, k + 1 steps of `gap` in front of it on the instrument's side
    # (the rays start eps = 1e-9 size off the detector; a self-hit tolerance is 1e-9 of the coordinates)
    gap = 1e-6 * max(hx, hy, *(abs(t) for t in frame.T))
    if analyzer and len(analyzer) * gap > 1e-3 * min(hx, hy):
        raise error(span, f"TRACE CAMERA {cam.name} ... STOKES: the camera lies too far from its frame's origin for "
                    f"analyzers on its face ({len(analyzer) * gap:.3g} m in front of a detector {2 * hx:.3g} m wide)",
                    "put the instrument in a GROUP and PLACE it: its own coordinates then stay small")
    n_obj = (surf.frame.R[2], surf.frame.R[5], surf.frame.R[8])      # the detector's normal, object frame
    itf = cam.interface          # a detector object without an INTERFACE sits in air
    medium = "AIR" if itf is None else (itf.front if side > 0 else itf.back)
    for k, el in enumerate(analyzer):
        aname = f"CAMERA_ANALYZER_{k}"
        while aname in new_objs:
            aname += "_"
        a_surf = M.replace(surf, aperture=M.Aperture("RECT", (1.5 * hx, 1.5 * hy), surf.span),
                           frame=surf.frame.shifted(tuple(side * (k + 1) * gap * n for n in n_obj)))
        itf = M.Interface(el[0], None, medium, medium, span, el[1], el[2] if len(el) > 2 else 0.0)
        new_objs[aname] = M.SceneObject(aname, (a_surf,), cam.transform, itf, (), None, cam.group, span)
    media = {}
    for k, m in scene.media.items():
        vol = m.params.get("volume") if m.params else None
        if vol is not None:
            m = M.replace(m, params=M.frozen_params({**m.params, "volume": {**vol, "toward": lname, "rays": 1}}))
        media[k] = m
    src = M.Source("CAMERA", M.frozen_params(dict(
        extent=extent, nx=i1 - i0, ny=j1 - j0, sub=params["sub"], side=side, aim=params["aim"], frame=frame,
        pixel_area=px * py * (math.pi / 4 if ellipse else 1.0), ellipse=ellipse, light_radius=lp["radius"],
        light_flux=light.flux, response=response, spectral=spectral, directions=int(params.get("directions") or 0),
        correlated=bool(params.get("correlated")), hero=int(params.get("hero") or 0),
        paired=spectral_paired(spectral, int(params.get("directions") or 0)))),
        cam.group, light.flux, span)
    sc2 = M.replace(scene, objects=M.frozen_params(new_objs), media=M.frozen_params(media), sources=(src,))
    m = int(params.get("directions") or 0)
    info = dict(camera=cam.name, light=lname, window=(i0, i1, j0, j1),
                rays_per_pixel_line=params["sub"] ** 2 * (2 * m * m if m else 1),
                paired=m > 0 or spectral_paired(spectral, m), directions=m,
                correlated=bool(params.get("correlated")), hero=int(params.get("hero") or 0),
                side=side,
                # samples: the rays per point behind one pixel of one image: SPECTRAL k draws k lines per
                # point (an image takes its share of them); every line traced: a FILTERS image sums them
                # all, a line's own image has only its own (the other lines' rays are not its zeros)
                lines=sum(mask), spectral=spectral,
                samples=spectral if spectral > 0 else sum(mask) if filters else 1,
                pixel_size=(px, py))
    return sc2, info


#: a GUIDE's defaults: the share of every table spread uniformly over the cells next to those where the pilot saw
#: light leave (so that a cell the pilot missed at an edge of the clear aperture keeps a fair share), the share
#: spread over all cells (so that no cell is left out: the largest weight factor is 1 / GUIDE_FLOOR), the tiles
#: per side of the camera's start lattice, and the pilot's start points per tile and side.  Until 2026-12-05 one
#: uniform share of 0.1 did both; a tenth of a Cassegrain's rays then went where a third of the cone is blocked
#: (docs/tracer.md, "Camera-side images")
GUIDE_NEAR = 0.05
GUIDE_FLOOR = 0.02
GUIDE_TILES = 4
GUIDE_PILOT_SUB = 4


def _in_group(scene: M.Scene, group: str | None, top: str) -> bool:
    while group is not None:
        if group == top:
            return True
        group = scene.groups[group].parent
    return False


def instrument_objects(csc: M.Scene, camera: str, light: str) -> set:
    """The keys of a camera scene's instrument objects: the camera's GROUP (with its subgroups), or for a camera
    outside any group the objects without SCATTER specs (the light aside)."""
    cam = csc.objects[camera]
    if cam.group is not None:
        return {k for k, o in csc.objects.items() if _in_group(csc, o.group, cam.group)}
    return {k for k, o in csc.objects.items() if not o.scatter and o.name != light}


def guide_pilot(csc: M.Scene, params: dict, info: dict, span: Span, target: tuple) -> tuple[M.Scene, dict]:
    """The pilot trace of a camera's GUIDE (docs/tracer.md, "Camera-side images"): which of the aim cone's g x g
    cells (the DIRECTIONS strata) lead out of the instrument to the scene, per tile of the camera's window.

    The pilot scene keeps the instrument's objects (``instrument_objects``) as the camera trace has them
    (mirrors, windows, baffles, the analyzers), without their SCATTER specs, and puts in place of everything
    else one absorbing sphere, `target` ((world centre, radius): about the centre of the scene's other objects,
    half as wide as they are far, so that what it measures is the instrument's transmission, not where the
    scene's own edges fall in a tile).  A ray that reaches it is tallied by its cell and tile (its source
    reports them as its start point: ``DETECTOR ... START``).  The pilot's source is the camera's own, over
    t x t tiles of the window with GUIDE_PILOT_SUB^2 stratified points each, two rays per cell (DIRECTIONS g),
    on one line (the mirrors' reflectance only scales the tally).  A camera in a GROUP is traced in that group's
    own frame (the group unplaced, the target brought into it to 9 digits), so the same instrument placed anew
    gives the same pilot, and the same key (``pilot_key``)."""
    g = int(params["guide"])
    src = csc.sources[0]
    p = dict(src.params)
    i0, i1, j0, j1 = info["window"]
    t = max(1, min(GUIDE_TILES, i1 - i0, j1 - j0))
    keep = instrument_objects(csc, params["camera"], info["light"])
    L = csc.n_lines
    cname = "CAMERA_GUIDE_TARGET"
    while cname in csc.objects:
        cname += "_"
    centre, radius = target
    groups = csc.groups
    grp = csc.objects[params["camera"]].group
    if grp is not None:
        # traced in the camera's group's own frame (the group unplaced, the target brought into it, to 9 digits):
        # an instrument placed anew (the flagship's telescope, every hour) gives the same pilot, bit for bit, so
        # its tables come from the cache
        G = csc.world_transform(M.SceneObject("", (), group=grp))
        d = [float(c) - G.T[k] for k, c in enumerate(centre)]
        centre = tuple(float(f"{sum(G.R[3 * k + i] * d[k] for k in range(3)):.9g}") for i in range(3))
        radius = float(f"{float(radius):.9g}")
        groups = M.frozen_params({k: (M.replace(v, placement=M.IDENTITY, parent=None) if k == grp else v)
                                  for k, v in groups.items() if _in_group(csc, k, grp)})
    catcher = M.SceneObject(
        cname, (M.Surface("SPHERE", M.frozen_params({"radius": float(radius)}),
                          M.Transform(T=tuple(float(x) for x in centre)), None, span),),
        interface=M.Interface("absorb", None, "AIR", "AIR", span),
        detector=M.Detector(g * g, t * t, span, filters=(("GUIDE", (1.0,) * L),), start=(0.0, g * g, 0.0, t * t)),
        group=grp, span=span)
    objs = {k: M.replace(o, scatter=()) for k, o in csc.objects.items() if k in keep}
    objs[cname] = catcher
    resp = [max(r) for r in p["response"]]
    line = max(range(L), key=lambda k: resp[k])
    # (hero_offset: the camera's HERO blocks start where its trace's seed says, which the pilot, one line and no
    # HERO, does not use; kept, it made a new pilot in 7 of the flagship's 25 frames)
    p.update(nx=t, ny=t, sub=GUIDE_PILOT_SUB, spectral=0, directions=g, correlated=False, paired=False, hero=0,
             hero_offset=0, response=tuple((1.0,) if k == line else (0.0,) for k in range(L)),
             guide={"g": g, "t": t, "pilot": True})
    pilot = M.replace(csc, objects=M.frozen_params(objs), groups=groups,
                      sources=(M.replace(src, params=M.frozen_params(p)),))
    return pilot, {"g": g, "t": t, "catcher": cname, "kept": len(keep)}


def _content(x):
    """What a model value holds, without where it was written (its spans): a key that two scripts, or two lines
    of one script, defining the same thing share."""
    import dataclasses
    from collections.abc import Mapping

    if isinstance(x, Span):
        return None
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return (type(x).__name__,) + tuple((f.name, _content(getattr(x, f.name))) for f in dataclasses.fields(x)
                                           if f.name not in ("span", "placed"))
    if isinstance(x, Mapping):
        return tuple((k, _content(v)) for k, v in x.items())
    if isinstance(x, (tuple, list)):
        return tuple(_content(v) for v in x)
    return x


def pilot_key(pilot: M.Scene, level: int) -> str:
    """A GUIDE pilot's identity: what it traces (the instrument, its media and coatings, the target, the
    source, the lines, LEVEL), not where the script wrote it; equal keys give equal tables."""
    import hashlib

    what = (pilot.objects, pilot.sources, pilot.groups, pilot.media, pilot.coatings, pilot.wavelengths_nm, level)
    return hashlib.sha1(repr(_content(what)).encode()).hexdigest()


def guide_tables(passed, g: int, t: int, near_share: float | None = None) -> tuple[tuple, dict]:
    """The GUIDE's tables from its pilot's tally `passed` ((t^2, g^2): the flux that left the instrument per tile
    and cell; a cell is c = a g + r, a the azimuth band and r the band in cos(angle), as the DIRECTIONS strata
    are numbered): per tile the pmf
        (1 - NEAR - GUIDE_FLOOR) share / total + NEAR near / n_near + GUIDE_FLOOR / g^2,
    NEAR the `near_share` (TRACE CAMERA ... NEAR; GUIDE_NEAR by default),
    near the cells where the pilot saw light leave and their neighbours (8 of them: the azimuth wraps around,
    the radial bands do not), n_near their number.  The floor leaves no cell out, so the guided estimate stays
    unbiased wherever light can come from; the near share bounds the weight of a cell at the clear aperture's
    edge that the pilot missed.  A tile the pilot saw nothing leave stays uniform.  Also the share of the
    directions that leave the instrument, uniform and guided (the pilot's estimates, each cell's tally over its
    tile's largest: the cells wholly clear)."""
    import numpy as np

    passed = np.maximum(np.asarray(passed, float).reshape(t * t, g * g), 0.0)
    tot = passed.sum(axis=1, keepdims=True)
    seen = (passed > 0).reshape(t * t, g, g)       # (tile, azimuth band, radial band)
    near = seen | np.roll(seen, 1, axis=1) | np.roll(seen, -1, axis=1)
    grown = near.copy()
    grown[:, :, 1:] |= near[:, :, :-1]
    grown[:, :, :-1] |= near[:, :, 1:]
    near = grown.reshape(t * t, g * g).astype(float)
    near /= np.maximum(near.sum(axis=1, keepdims=True), 1.0)
    ns = GUIDE_NEAR if near_share is None else float(near_share)
    pmf = np.where(tot > 0, (1 - ns - GUIDE_FLOOR) * passed / np.where(tot > 0, tot, 1.0)
                   + ns * near + GUIDE_FLOOR / (g * g), 1.0 / (g * g))
    pmf /= pmf.sum(axis=1, keepdims=True)
    top = passed.max(axis=1, keepdims=True)
    frac = np.where(top > 0, passed / np.where(top > 0, top, 1.0), 0.0)
    stats = {"uniform": float(frac.mean()), "guided": float((pmf * frac).sum(axis=1).mean())}
    return tuple(pmf.ravel()), stats


def with_guide(csc: M.Scene, pmf: tuple, g: int, t: int) -> M.Scene:
    """The camera scene with its source drawing its directions from the GUIDE's tables."""
    src = csc.sources[0]
    p = dict(src.params, guide={"g": g, "t": t, "pmf": pmf})
    return M.replace(csc, sources=(M.replace(src, params=M.frozen_params(p)),))
