/* The entropy coder of `transform` payloads of versions 2 and 3: an adaptive binary arithmetic coder with context
 * mixing over the quantised wavelet coefficients of a clip (specs/codecs.md, "Payload version 2"; version 3 is the
 * same coder whose fixed-context counters start from trained states, "Payload version 3").
 *
 * Plain C99, no Python, integer arithmetic only (the same bytes on every CPU and compiler that follows the C
 * standard's integer rules). Every count and range read from a payload is checked before it is used; a damaged
 * payload gives an error code, never a crash or a read outside the buffer.
 */
#ifndef MRCODER_H
#define MRCODER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Limits of a payload (checked by the decoder; the encoder refuses what it could not write). */
#define MRC_MAX_FEATURES (1L << 20)        /* D */
#define MRC_MAX_FRAMES 4294967296LL        /* F */
#define MRC_MAX_REGION 65536L              /* frames per region */
#define MRC_MAX_EXPONENT 32767L            /* |step exponent| */
#define MRC_MAX_BITS 62                    /* a coefficient's magnitude is below 2 ** 62 */
#define MRC_VALUES_PER_BYTE 4096LL         /* F * D + D + R <= this * payload bytes */

/* Error codes (0 is success). mrc_error_text() gives one line for each. */
enum {
    MRC_OK = 0,
    MRC_E_HEADER = 1,      /* the head (frames, features, region) is malformed or out of range */
    MRC_E_TOO_MANY = 2,    /* more values than the bytes can hold */
    MRC_E_EXPONENT = 3,    /* a step exponent out of range */
    MRC_E_MAGNITUDE = 4,   /* a coefficient out of range */
    MRC_E_TRUNCATED = 5,   /* the coded data ends early */
    MRC_E_TRAILING = 6,    /* bytes after the coded data that are not zero */
    MRC_E_MEMORY = 7,      /* out of memory */
    MRC_E_ARGUMENT = 8     /* an argument the encoder cannot code */
};

const char *mrc_error_text(int code);

/* Levels of the wavelet of F frames and the sizes of the F rows' bands in storage order (approximation, then
 * details of levels L..1): the same as motionrep_transform._wavelet.num_levels / level_sizes. `sizes` must hold
 * 21 entries; returns L. */
int mrc_level_sizes(int64_t frames, int64_t *sizes);

/* The head of a payload: frames F, features D, region frames (each within its limit). Returns an error code. */
int mrc_declared(const uint8_t *data, size_t len, int64_t *frames, int64_t *features, int64_t *region);

/* Whether a payload of `len` bytes may declare these counts: F * D + D + R <= MRC_VALUES_PER_BYTE * len (the
 * decoder refuses a payload that does not, before anything is allocated). */
int mrc_fits(int64_t frames, int64_t features, int64_t region, size_t len);

/* Encode. coef: F x D int64, row-major, the bands stacked in storage order; fexp (D), rexp (R = ceil(F /
 * region)). On success *out is a malloc'ed buffer of *out_len bytes (free it with free()). */
int mrc_encode(int64_t frames, int64_t features, int64_t region, const int64_t *fexp, const int64_t *rexp,
               const int64_t *coef, uint8_t **out, size_t *out_len);

/* Decode into caller-allocated arrays of the sizes mrc_declared gives (fexp D, rexp R, coef F x D). */
int mrc_decode(const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef);

/* The same with the coefficients feature-major when `feature_major` (coef[d * F + f]; the bands of a feature one
 * after the other in storage order, as mrtransform's in-place synthesis takes them), else row-major (mrc_decode). */
int mrc_decode_layout(const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                      int feature_major);

/* The same three for a payload `version` 2 or 3 (the functions above are version 2; the head and the limits are
 * the same in both; MRC_E_ARGUMENT for another version). */
int mrc_encode_version(int version, int64_t frames, int64_t features, int64_t region, const int64_t *fexp,
                       const int64_t *rexp, const int64_t *coef, uint8_t **out, size_t *out_len);
int mrc_decode_version(int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                       int feature_major);

/* The same as mrc_decode_version by code_body's generic loop (the encoder's, run in the decoding direction) instead
 * of the decoder's own loop over the details: the reference the fast loop is tested against (the same integers and
 * the same error code from any bytes). */
int mrc_decode_reference(int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                         int feature_major);

/* For the generator of mrprior3.h (benchmarks/prior3.py) only: code these integers as version 2 does and give the
 * final state of each fixed-context counter (MRC_STATES of them, in mrprior3.h's order): its probability in
 * stretch units and its update count (capped at 63). Returns an error code. */
#define MRC_STATES 6683
int mrc_states(int64_t frames, int64_t features, int64_t region, const int64_t *fexp, const int64_t *rexp,
               const int64_t *coef, int16_t *stretch, uint16_t *count);

#ifdef __cplusplus
}
#endif
#endif
