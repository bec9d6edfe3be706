"""The compiled extensions (C, built by the machine's C compiler at install time); the package's metadata is in
pyproject.toml.

Flags: ``-O3`` without ``-march=native`` (a payload must decode to the same bits on any x86-64 CPU, so no code
may depend on the machine that built it), ``-ffp-contract=off`` (no product and sum fused into one operation)
and ``-fno-fast-math``: every floating-point operation is one IEEE operation, in the order the source writes it.
One ``Extension`` per compiled module.
"""

from setuptools import Extension, setup

#: the flags every extension is compiled with (see above)
CFLAGS = ["-std=c11", "-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-trapping-math"]

setup(ext_modules=[
    Extension("motionrep._ccore",
              sources=["motionrep/_c/module.c", "motionrep/_c/numbers.c", "motionrep/_c/shortest.c",
                       "motionrep/_c/fk.c", "motionrep/_c/rotations.c", "motionrep/_c/edits.c"],
              depends=["motionrep/_c/ccore.h", "motionrep/_c/mr_rotconv.h", "motionrep/_c/rotations_impl.h",
                       "motionrep/_c/fk_impl.h", "motionrep/_c/mr_twice.h"],
              extra_compile_args=CFLAGS),
    # the entropy coder of transform payloads of version 2 (integer arithmetic only)
    Extension("motionrep_transform._ccoder",
              sources=["plugins/motionrep_transform/_c/ccoder.c", "plugins/motionrep_transform/_c/mrcoder.c"],
              depends=["plugins/motionrep_transform/_c/mrcoder.h"],
              extra_compile_args=CFLAGS),
])
