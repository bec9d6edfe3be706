"""The compiled parts of motionrep, built by the machine's C compiler on ``pip install`` (pyproject.toml holds
everything else).

Every extension is compiled with the same flags: ``-O3`` (loops vectorised), ``-ffp-contract=off`` and
``-fno-fast-math`` (every operation IEEE, no fused multiply-add: a value is the same bits on any x86-64 or aarch64
CPU, in a vector lane or alone), ``-fno-math-errno`` (``sqrt`` without the ``errno`` branch, so loops over it
vectorise; it changes no value) and no ``-march=native`` (a wheel runs on any CPU of its architecture; the kernels
that need wider vectors carry their own AVX2 / AVX-512 copies, ``motionrep/_c/include/motionrep/mrkernels.h``).
One ``Extension`` per item of the list.
"""

import numpy
from setuptools import Extension, setup

FLAGS = ["-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-math-errno", "-fno-trapping-math"]
INCLUDE = ["motionrep/_c/include"]

EXTENSIONS = [
    # the pose plan and the runtime decoder's loop (motionrep.model.poseplan, motionrep.pipeline.runtime)
    # (numpy's C API: the one-pose path makes its fresh arrays in C)
    Extension("motionrep._cplan", sources=["motionrep/_c/plan/plan.c", "motionrep/_c/plan/module.c"],
              include_dirs=INCLUDE + ["motionrep/_c/plan", numpy.get_include()], depends=["motionrep/_c/plan/plan.h"],
              extra_compile_args=FLAGS),
    # the transform payload decoder: mrtransform.h/.c (no Python; an engine can embed it) and its binding
    Extension("motionrep_transform._cdecode",
              sources=["plugins/motionrep_transform/_c/mrtransform.c", "plugins/motionrep_transform/_c/module.c"],
              include_dirs=INCLUDE + ["plugins/motionrep_transform/_c"],
              depends=["plugins/motionrep_transform/_c/mrtransform.h"], extra_compile_args=FLAGS),
    # the svd codec's decoder
    Extension("motionrep_svd._csvd", sources=["plugins/motionrep_svd/_c/module.c"], include_dirs=INCLUDE,
              extra_compile_args=FLAGS),
    # the Fourier codecs' network decoder
    Extension("motionrep_fourier._cfourier", sources=["plugins/motionrep_fourier/_c/module.c"], include_dirs=INCLUDE,
              extra_compile_args=FLAGS),
]

setup(ext_modules=EXTENSIONS)
