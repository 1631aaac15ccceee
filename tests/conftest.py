"""Test-suite settings.

Hypothesis: the "ci" profile (default) derandomizes the property tests; HYPOTHESIS_PROFILE=explore draws new
examples (what a developer hunting for bugs runs).

The tracer compiles one kernel per kind of scene (`irtlang/compile/specialize.py`); a test suite that builds
dozens of kinds of scenes would spend most of its time compiling.  Tests therefore use one kernel with every
feature (IRT_KERNEL_FEATURES=all), except where a test sets it otherwise;
tests/physics/test_trace_specialization.py checks that specialized kernels give the same results.
"""
import os

from hypothesis import settings

os.environ.setdefault("IRT_KERNEL_FEATURES", "all")

# CI runs a fixed set of examples (derandomized) so a submission's result does not depend on luck; exploring
# new examples is a developer's run: `HYPOTHESIS_PROFILE=explore python -m pytest tests/unit/test_fuzz.py`.
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
