"""The pure core: physics, metrics, noise (numpy, numba, scipy, mpmath; no ROS import)."""
import numba as _numba

# LLVM's loop vectoriser versions the kernels' lane loops behind run-time alias checks that
# cost more than the packed code gains: without it an episode's step takes 30.2 instead of
# 38.2 us alone and 23.9 instead of 26.1 us per lane in a batch of 4 (time-min,
# docs/studies/step.md).  It changes no result (no fast-math: packed code computes the same
# IEEE operations, tests/test_kernel_golden.py).  numba reads it at each compilation, so it
# is set before any kernel is compiled.
_numba.config.LOOP_VECTORIZE = False
