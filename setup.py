"""The optional compiled kernels (sensorcfg/_kernel.c). Everything else is in pyproject.toml.

`optional=True`: without a C compiler the package installs without it, and sensorcfg does the same work
with numpy (sensorcfg/compiled.py; the noise numbers' reference is sensorcfg/noise/streams.py).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("sensorcfg._kernel", ["sensorcfg/_kernel.c"], optional=True,
                             libraries=["m"], extra_compile_args=["-O3", "-ffp-contract=off", "-fno-fast-math"])])
