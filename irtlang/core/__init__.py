"""Cross-cutting pieces every stage may use: diagnostics (positions, errors) and units.

The bottom layer of the import order (docs/architecture.md): modules here import nothing else from irtlang.
"""
