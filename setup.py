"""The optional compiled noise kernel (sensorcfg/noise/_philox.c). Everything else is in pyproject.toml.

`optional=True`: without a C compiler the package installs without it, and sensorcfg/noise/streams.py
computes the same numbers with numpy (the reference the tests compare the kernel against).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("sensorcfg.noise._philox", ["sensorcfg/noise/_philox.c"], optional=True,
                             libraries=["m"], extra_compile_args=["-O3", "-ffp-contract=off", "-fno-fast-math"])])
