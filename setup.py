"""Build of the compiled assembly kernel; everything else is in pyproject.toml.

app/assembly/_kernel.c is a plain C library on raw buffers (loaded through ctypes by
app/assembly/compiled.py), so it needs no numpy headers. It is optional: without a C
compiler the install still succeeds and assembly falls back to the numpy path.
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
        )
    ]
)
