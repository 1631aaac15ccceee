"""Test-suite settings.

The tracer compiles one kernel per kind of scene (`irtlang/compile/specialize.py`); a test suite that builds
dozens of kinds of scenes would spend most of its time compiling.  Tests therefore use one kernel with every
feature (IRT_KERNEL_FEATURES=all), except where a test sets it otherwise;
tests/physics/test_trace_specialization.py checks that specialized kernels give the same results.
"""
import os

os.environ.setdefault("IRT_KERNEL_FEATURES", "all")
