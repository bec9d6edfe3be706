/* The C face of a prepared codec decoder (Codec.decoder): how the runtime decoder (motionrep.open) calls a
 * compiled codec for each block of poses without going through Python.
 *
 * A decoder object offers it as its attribute `sampler`: a PyCapsule named MR_SAMPLER_CAPSULE holding a pointer
 * to an mr_sampler that stays valid as long as the decoder object (the capsule keeps a reference to it). The
 * runtime calls  sample(state, times, count, out, ldo)  with `times` count normalised times in [0, 1] and `out`
 * a feature-major block: feature d of time i at out[d * ldo + i], d < width, i < count <= ldo.  It must write the
 * values the decoder's Python call gives, keep no state between calls (several threads may call it with their
 * own `out`), never call into Python, and return 0 (or a non-zero code on failure: the runtime raises a
 * PayloadError).  `block` asks for that many times per call (the runtime decoder's block; 64 otherwise): a codec
 * that groups a call's times (the Fourier codecs, by window) works better on larger calls.
 */
#ifndef MOTIONREP_SAMPLER_H
#define MOTIONREP_SAMPLER_H

#include <stddef.h>

#define MR_SAMPLER_CAPSULE "motionrep.sampler.v1"
#define MR_SAMPLER_ABI 1

typedef int (*mr_sample_fn)(const void *state, const double *times, size_t count, double *out, size_t ldo);

typedef struct {
    int abi;             /* MR_SAMPLER_ABI */
    size_t width;        /* features per time, D */
    mr_sample_fn sample;
    const void *state;
    size_t block;        /* times the sampler prefers per call (a codec that groups its times, say), or 0: any */
} mr_sampler;

#endif
