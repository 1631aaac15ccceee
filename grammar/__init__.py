"""The irt grammar, shipped inside the wheel as ``irtlang.grammar``."""
from pathlib import Path

GRAMMAR_FILE = Path(__file__).with_name("irt.lark")
