/* mrtransform: the decoder of motionrep's `transform` payloads, in C, with no Python in it (specs/codecs.md,
 * "## `transform`").  It is the start of a decoder an engine can embed: payload bytes in, the decoded features of
 * every frame out, then sampled at any time.
 *
 *   mrt_status st;
 *   mrt_frames f;
 *   if (mrt_decode(data, size, 1, &f, &st) != MRT_OK) { puts(st.message); return; }
 *   mrt_sample(&f, times, count, out, count);     // out[d * count + i]: feature d at times[i]
 *   mrt_frames_free(&f);
 *
 * Bits: the same values as motionrep's own decoder in Python and numpy (the one it replaced), on any CPU, when
 * compiled without fused multiply-add and fast-math (gcc/clang: -ffp-contract=off, no -ffast-math): the range
 * decoder and its models are constriction 0.5's (`stream.queue.RangeDecoder`, `stream.model.Categorical(perfect=
 * False)`, `Uniform`) in integer arithmetic and IEEE double operations, the inverse wavelet the same operations in
 * the same order.
 *
 * Hostile data: every count and range is checked before anything is allocated or read (a payload cannot declare
 * more values than its bytes can hold), every read is in bounds, and a damaged payload ends in one of the error
 * messages motionrep's Python decoder gave (mrt_status.message), never in a crash.
 *
 * Versions: `version` is the payload's format version: 1 (static models stored in the payload, a range coder:
 * parsed here), 2 (an adaptive binary coder with context mixing: its integers decoded by mrcoder.c, which an
 * engine builds beside this file) or 3 (version 2's coder with trained starting states, mrcoder.c and mrprior3.h).  A version has its own integer decoder (mrt_unpack) and shares the rest
 * (dequantisation, wavelet, sampling).
 */
#ifndef MRTRANSFORM_H
#define MRTRANSFORM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MRT_MAX_VERSION 3
#define MRT_MAX_LEVELS 20
#define MRT_MAX_EXPONENT 32767  /* largest magnitude of a step exponent (steps are 2 ** (exponent / 8)) */
#define MRT_MAX_ZERO 208        /* largest zero index of a stored model */

typedef enum {
    MRT_OK = 0,
    MRT_DAMAGED = 1,    /* the payload is damaged or inconsistent (message says how) */
    MRT_NO_MEMORY = 2,  /* an allocation failed */
    MRT_VERSION = 3,    /* a payload version this decoder does not know */
    MRT_ARGUMENT = 4    /* a call with arguments that do not fit (a bug of the caller) */
} mrt_code;

typedef struct {
    int code;           /* an mrt_code */
    char message[200];  /* one line, what is wrong */
} mrt_status;

/* What a payload holds, before dequantisation: step exponents and quantised wavelet coefficients. */
typedef struct {
    uint64_t frames;             /* F >= 1 */
    uint64_t features;           /* D >= 1 */
    uint64_t region_frames;      /* frames per region of the step envelope */
    uint64_t regions;            /* R = ceil(F / region_frames) */
    int levels;                  /* wavelet levels L (0..20) */
    uint64_t sizes[MRT_MAX_LEVELS + 1];  /* rows of each coefficient array: approximation, detail L, ..., 1 */
    int64_t *feature_exponents;  /* (D,) */
    int64_t *region_exponents;   /* (R,) */
    int64_t *coefficients;       /* the arrays of `sizes` one after the other, each (rows, D) row-major: F x D */
} mrt_quantised;

/* The decoded features of every frame (frame i at time i / (F - 1)). */
typedef struct {
    uint64_t frames;    /* F */
    uint64_t features;  /* D */
    double *values;     /* feature-major: feature d of frame i at values[d * F + i] */
    double *rows;       /* NULL, or the same values frame-major (rows[i * D + d]), made by mrt_frames_rows */
} mrt_frames;

/* (F, D, region frames) the head of a payload of format `version` declares (nothing else is read). */
int mrt_declared(const uint8_t *data, size_t size, int version, uint64_t *frames, uint64_t *features,
                 uint64_t *region_frames, mrt_status *st);

/* Range-decode a payload into `q` (free it with mrt_quantised_free, also after an error). */
int mrt_unpack(const uint8_t *data, size_t size, int version, mrt_quantised *q, mrt_status *st);

/* Dequantise and transform back: the features of every frame (free with mrt_frames_free, also after an error).
 * `q` is not changed; its arrays may come from elsewhere (an encoder's candidate). */
int mrt_reconstruct(const mrt_quantised *q, mrt_frames *out, mrt_status *st);

/* mrt_unpack then mrt_reconstruct. */
int mrt_decode(const uint8_t *data, size_t size, int version, mrt_frames *out, mrt_status *st);

/* The features at `count` normalised times (clamped to [0, 1]; linear interpolation between frames, a time on a
 * frame gives the frame's values exactly): feature d of time i at out[d * ldo + i] (feature-major, ldo >= count),
 * or, with mrt_sample_rows, at out[i * D + d]. */
void mrt_sample(const mrt_frames *f, const double *times, size_t count, double *out, size_t ldo);
void mrt_sample_rows(const mrt_frames *f, const double *times, size_t count, double *out);

/* A frame-major copy of the values (8 F D more bytes), with which mrt_sample reads each time's two frames as
 * contiguous rows: faster for many times in random order (a runtime decoder); the same values.  MRT_OK or
 * MRT_NO_MEMORY. */
int mrt_frames_rows(mrt_frames *f);

/* The inverse CDF 9/7 wavelet of one feature: x holds its coefficients in storage order (approximation, detail L,
 * ..., detail 1; row counts `sizes`, as mrt_levels gives them), replaced by the samples; tmp holds as many doubles. */
void mrt_inverse(double *x, const uint64_t *sizes, int levels, double *tmp);
/* The forward transform of x (in place, into mrt_inverse's layout; tmp holds sizes' total): the encoder's. */
void mrt_forward(double *x, const uint64_t *sizes, int levels, double *tmp);

/* The encoder's rounding (motionrep_transform/_plan.py): for the rows r of c (n, m) (subset[0 .. count), or every
 * row: subset NULL, count n), q[r, j] = sign(c) floor(|c| / step + rounding), step = table[rows[r] * width +
 * cols[j]] (table K x width), and dq[r, j] = q step (q as a float64), numpy's elementwise IEEE operations in that
 * order.  work: K m + 256 m doubles.  Returns -1 when a floor is not below 2**62 (an integer above MAX_MAGNITUDE = 2**62
 * - 1, or NaN: q and dq then incomplete); else, with compare, 1 when every dq written equals (==) the value it
 * overwrote, 0 when one differs (0 without compare). */
int mrt_round(const double *c, int64_t m, const double *table, int64_t K, int64_t width, const int64_t *rows,
              const int64_t *cols, double rounding, int64_t *q, double *dq, const int64_t *subset, int64_t count,
              int compare, double *work);

/* The number of wavelet levels of F frames and the row counts of the coefficient arrays (sizes[0..levels]). */
int mrt_levels(uint64_t frames, uint64_t *sizes);

void mrt_quantised_free(mrt_quantised *q);
void mrt_frames_free(mrt_frames *f);

/* The most values `bytes` of coded data can hold when every model's zero index is at most MRT_MAX_ZERO. */
uint64_t mrt_max_values(uint64_t bytes);

/* ---- the range decoder and its models, for tests and for other payloads ---------------------------------- */

#define MRT_TOKENS 74   /* magnitudes 0..15, then one token per bit length 5..62 */

typedef struct {
    const uint8_t *data;  /* little-endian 32-bit words */
    size_t words, pos;
    uint64_t lower, range, point;
} mrt_range_decoder;

/* left cumulative frequency of each token at 24-bit precision, left[MRT_TOKENS] = 2^24 */
typedef struct {
    uint32_t left[MRT_TOKENS + 1];
} mrt_model;

void mrt_range_init(mrt_range_decoder *rd, const uint8_t *data, size_t size);  /* size: a multiple of 4 */
void mrt_model_build(int zero, int decay, mrt_model *m);
/* one symbol under `m` / of `bits` uniform bits (1..16): 0, or -1 for data no model could have written */
int mrt_range_symbol(mrt_range_decoder *rd, const mrt_model *m, int *symbol);
int mrt_range_uniform(mrt_range_decoder *rd, int bits, uint32_t *symbol);
int mrt_range_maybe_exhausted(const mrt_range_decoder *rd);
/* `count` integers under model (zero, decay) as motionrep.plugin.coding.IntegerDecoder.decode reads them */
int mrt_decode_integers(mrt_range_decoder *rd, const mrt_model *m, size_t count, int64_t *out, mrt_status *st);

#ifdef __cplusplus
}
#endif

#endif
