"""Strict test configuration: float64, no silent rank promotion, fixed seeds."""

import os

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=2")
os.environ.setdefault("MPLBACKEND", "Agg")
# No persistent compilation cache for what the suite runs (the commands it calls would switch it
# on in this process): writing every compiled program of a long session to it crashed the
# process twice inside XLA's executable serialisation (jaxlib 0.10.2). The tests of the cache
# and of the stored programs point JAX at a folder of their own.
os.environ.setdefault("TYREBAYES_JAX_CACHE", "")

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
