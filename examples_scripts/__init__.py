"""The example scripts, installed as irtlang.examples (`irt examples` lists and copies them; an INCLUDE that is
not found next to the including script is looked up here, see irtlang/library.py)."""
