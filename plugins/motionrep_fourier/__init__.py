"""Shipped plugin: the Fourier-feature network codecs of Tojo et al. (2022).

* ``adaptive-fourier``: Algorithm 1, frequencies chosen one at a time from the DCT of the residual's first
  principal component, the network grown with a warm start;
* ``naive-fourier``: the §4.1 baseline, frequencies ``1, 2, ..., K`` cycles over the clip.

Training is numpy (imported inside ``encode`` only, one BLAS thread); decoding is numpy.  See ``specs/codecs.md``.
"""

from __future__ import annotations

from motionrep import __version__
from motionrep.plugin.hookspecs import hookimpl

from ._codecs import AdaptiveFourierCodec, FourierParams, NaiveFourierCodec

__all__ = ["AdaptiveFourierCodec", "NaiveFourierCodec", "FourierParams", "register_codecs", "__version__"]


@hookimpl
def register_codecs(register):
    """Register :class:`AdaptiveFourierCodec` and :class:`NaiveFourierCodec`."""
    register(AdaptiveFourierCodec())
    register(NaiveFourierCodec())
