"""The compiled extensions (C, built by the machine's C compiler when motionrep is installed); the package's
metadata is in pyproject.toml.

Every extension is compiled with the same flags: ``-std=c11``, ``-O3`` (loops vectorised), ``-ffp-contract=off`` and
``-fno-fast-math`` (every floating-point operation is one IEEE operation, in the order the source writes it, no
product and sum fused into one: a value is the same bits on any x86-64 or aarch64 CPU, in a vector lane or
alone), ``-fno-math-errno`` and ``-fno-trapping-math`` (``sqrt`` without its ``errno`` branch, selects instead of
branches, so the loops over them vectorise; they change no value), and no ``-march=native`` (a payload must
decode to the same bits on any CPU, and a wheel must run on any CPU of its architecture: the kernels that need
wider vectors carry their own AVX2 / AVX-512 copies, ``motionrep/_c/include/motionrep/mrkernels.h``).
One ``Extension`` per compiled module.
"""

import numpy
from setuptools import Extension, setup

#: the flags every extension is compiled with (see above)
FLAGS = ["-std=c11", "-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-math-errno", "-fno-trapping-math"]
#: motionrep's installed C headers (mrkernels.h, sampler.h, pybuf.h)
INCLUDE = ["motionrep/_c/include"]
TRANSFORM = "plugins/motionrep_transform/_c"
#: the shared kernels' headers (an extension that includes them is rebuilt when they change)
KERNELS = ["motionrep/_c/include/motionrep/mrkernels.h", "motionrep/_c/include/motionrep/sampler.h",
           "motionrep/_c/include/motionrep/pybuf.h"]

setup(ext_modules=[
    # BVH numbers and writer, FK, rotation conversions and continuity (motionrep.io, motionrep.model)
    Extension("motionrep._ccore",
              sources=["motionrep/_c/module.c", "motionrep/_c/numbers.c", "motionrep/_c/shortest.c",
                       "motionrep/_c/fk.c", "motionrep/_c/rotations.c", "motionrep/_c/edits.c",
                       "motionrep/_c/euler.c", "motionrep/_c/chain.c"],
              depends=["motionrep/_c/ccore.h", "motionrep/_c/mr_rotconv.h", "motionrep/_c/rotations_impl.h",
                       "motionrep/_c/chain_impl.h", "motionrep/_c/fk_impl.h", "motionrep/_c/mr_twice.h"],
              extra_compile_args=FLAGS),
    # the pose plan and the runtime decoder's loop (motionrep.model.poseplan, motionrep.pipeline.runtime)
    # (numpy's C API: the one-pose path makes its fresh arrays in C)
    Extension("motionrep._cplan", sources=["motionrep/_c/plan/plan.c", "motionrep/_c/plan/module.c"],
              include_dirs=INCLUDE + ["motionrep/_c/plan", numpy.get_include()],
              depends=["motionrep/_c/plan/plan.h", "motionrep/_c/mr_rotconv.h"] + KERNELS,
              extra_compile_args=FLAGS),
    # the transform payload decoder: mrtransform.h/.c (no Python; an engine can embed it, with mrcoder.c and
    # mrprior3.h for payload versions 2 and 3) and its binding
    Extension("motionrep_transform._cdecode",
              sources=[f"{TRANSFORM}/mrtransform.c", f"{TRANSFORM}/mrcoder.c", f"{TRANSFORM}/module.c"],
              include_dirs=INCLUDE + [TRANSFORM],
              depends=[f"{TRANSFORM}/mrtransform.h", f"{TRANSFORM}/mrcoder.h", f"{TRANSFORM}/mrprior3.h"],
              extra_compile_args=FLAGS),
    # the entropy coder of transform payloads of versions 2 and 3 (integer arithmetic only), for encoding
    Extension("motionrep_transform._ccoder", sources=[f"{TRANSFORM}/ccoder.c", f"{TRANSFORM}/mrcoder.c"],
              depends=[f"{TRANSFORM}/mrcoder.h", f"{TRANSFORM}/mrprior3.h"], extra_compile_args=FLAGS),
    # the svd codec's decoder
    Extension("motionrep_svd._csvd", sources=["plugins/motionrep_svd/_c/module.c"], include_dirs=INCLUDE,
              depends=KERNELS + ["motionrep/_c/mr_rotconv.h"], extra_compile_args=FLAGS),
    # the Fourier codecs' network decoder
    Extension("motionrep_fourier._cfourier", sources=["plugins/motionrep_fourier/_c/module.c"], include_dirs=INCLUDE,
              extra_compile_args=FLAGS),
])
