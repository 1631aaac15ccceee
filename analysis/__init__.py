"""irtlang analysis: pure functions of arrays and saved files (filled by the analysis issue)."""
