"""Build of the compiled C parts; everything else is in pyproject.toml.

app/assembly/_kernel.c is a plain C library on raw buffers (loaded through ctypes by
app/assembly/compiled.py), so it needs no numpy headers; app/_hard_stop.c is a signal
handler (app/hard_stop.py). Both are optional: without a C compiler the install still
succeeds, assembly falls back to the numpy path and a signal during a long PETSc call on
several ranks leaves the status `running` (README, "Exit status").
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "app.assembly._kernel",
            sources=["app/assembly/_kernel.c"],
            depends=["app/assembly/_kernel_rows.h"],
            extra_compile_args=["-O3"],
            optional=True,
        ),
        Extension(  # the status on a signal during a long PETSc call (app/hard_stop.py)
            "app._hard_stop",
            sources=["app/_hard_stop.c"],
            extra_compile_args=["-O2"],
            optional=True,
        ),
    ]
)
