"""Plugins: one module per surface, scatter-model (BSDF) and source kind.

A plugin module declares ``KIND`` (its keyword), ``FORM`` (its parameters, with units and checks, in the
signature language of ``irtlang.lang.spec``), ``EXAMPLE`` (a script fragment the docs and tests run), a
docstring with its parameter table, and ``build(bound, ctx)`` that turns bound arguments into model
parameters in canonical units.  The tracer issues add the kernels (``intersect``/``normal`` for surfaces;
``sample``/``eval``/``pdf`` for BSDFs) to the same modules.  Adding a kind is that module plus one line in
its package's ``REGISTRY``.
"""
import importlib


def load_registry(package: str, names: list[str]) -> dict:
    mods = {}
    for n in names:
        m = importlib.import_module(f"{package}.{n}")
        mods[m.KIND] = m
    return mods
