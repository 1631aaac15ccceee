"""The Numba kernels.  Importing the package installs the compile-time speedups of
``irtlang.kernels.numba_speedups`` (same machine code, shorter first compile)."""
from .numba_speedups import install as _install_numba_speedups

_install_numba_speedups()
