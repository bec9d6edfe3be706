/* mrtransform: the `transform` payload decoder (see mrtransform.h; the format is specs/codecs.md, "## `transform`",
 * and specs/coding.md for version 1's integer coding; versions 2 and 3's integers are mrcoder.c's).  Standard C99 and
 * libm's floor, ceil and ldexp (exact operations), nothing else. */
#include "mrtransform.h"

#include "mrcoder.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* gcc on x86-64 Linux: an AVX2 and an AVX-512 copy of the loops beside the baseline one, picked at load time by
 * the CPU (the same IEEE operations in each, so the same bits; define MRT_NO_CLONES to build one copy) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && !defined(MRT_NO_CLONES)
#define MRT_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define MRT_CLONES
#endif

#define PRECISION 24
#define DIRECT 16        /* magnitudes below this are their own token */
#define FIRST_BUCKET 4   /* token DIRECT + e - FIRST_BUCKET: magnitudes in [2^e, 2^(e+1)) */
#define CHUNK 16         /* raw bits are coded in chunks of at most this many bits */
#define SIZES 8          /* context classes per (pass, level group) */
#define FINE 3           /* detail levels 1..3 form the fine group */
#define CONTEXTS 32
#define TIMES 512        /* times sampled together */

#if defined(__GNUC__)
#define MRT_RESTRICT __restrict__
#else
#define MRT_RESTRICT
#endif

/* ldexp(1 / -log2(P(0) at zero index 208), 0): what motionrep.plugin.coding.max_values computes, to the bit */
static const double PER_BIT = 0x1.63108a9cac6fdp+9;

/* CDF 9/7 lifting steps (JPEG 2000 Part 1, Annex F) and subband scaling, as motionrep_transform._wavelet */
static const double STEPS[4] = {-1.586134342059924, -0.052980118572961, 0.882911075530934, 0.443506852043971};
static const double LOW = 1.1496043988602411, HIGH = 0.8698644516247813;
/* 2 ** (i / 8), i = 0..7, as motionrep.plugin.coding._EIGHTH_ROOTS */
static const double EIGHTH_ROOTS[8] = {1.0, 1.0905077326652577, 1.189207115002721, 1.2968395546510096,
                                       1.4142135623730951, 1.5422108254079407, 1.681792830507429,
                                       1.8340080864093424};

static const char INVALID[] = "coded integers are damaged (Tried to decode from compressed data that is invalid "
                              "for the employed entropy model.)";

static int fail(mrt_status *st, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(st->message, sizeof st->message, fmt, ap);
    va_end(ap);
    st->code = code;
    return code;
}

static int ok(mrt_status *st)
{
    st->code = MRT_OK;
    st->message[0] = 0;
    return MRT_OK;
}

/* ---- the range decoder (constriction 0.5's RangeDecoder<u32, u64>, PRECISION 24) --------------------------- */

static uint32_t word_at(const uint8_t *d, size_t i)
{
    d += 4 * i;
    return (uint32_t)d[0] | (uint32_t)d[1] << 8 | (uint32_t)d[2] << 16 | (uint32_t)d[3] << 24;
}

void mrt_range_init(mrt_range_decoder *rd, const uint8_t *data, size_t size)
{
    rd->data = data;
    rd->words = size / 4;
    rd->pos = 0;
    rd->lower = 0;
    rd->range = UINT64_MAX;
    uint64_t point = 0;
    int read = 0;
    while (read < 2 && rd->pos < rd->words) {
        point = (point << 32) | word_at(data, rd->pos++);
        read++;
    }
    if (read == 1)
        point <<= 32;
    rd->point = point;
}

static inline void advance(mrt_range_decoder *rd, uint64_t scale, uint32_t left, uint32_t probability)
{
    rd->lower += scale * left;
    rd->range = scale * probability;
    if (rd->range < (uint64_t)1 << 32) {
        rd->lower <<= 32;
        rd->range <<= 32;
        rd->point <<= 32;
        if (rd->pos < rd->words)
            rd->point |= word_at(rd->data, rd->pos++);
    }
}

static inline int range_symbol(mrt_range_decoder *rd, const mrt_model *m, int *symbol)
{
    /* the symbol s with left[s] <= (point - lower) / scale < left[s + 1], found without dividing: q < L exactly
     * when point - lower < L scale (L scale < 2^64: L <= 2^24, scale < 2^40); past the last symbol, InvalidData */
    uint64_t scale = rd->range >> PRECISION, diff = rd->point - rd->lower;
    int s = 0;
    while (diff >= scale * m->left[s + 1]) {
        if (++s == MRT_TOKENS)
            return -1;
    }
    advance(rd, scale, m->left[s], m->left[s + 1] - m->left[s]);
    *symbol = s;
    return 0;
}

int mrt_range_symbol(mrt_range_decoder *rd, const mrt_model *m, int *symbol)
{
    return range_symbol(rd, m, symbol);
}

int mrt_range_uniform(mrt_range_decoder *rd, int bits, uint32_t *symbol)
{
    int shift = PRECISION - bits;
    uint64_t scale = rd->range >> PRECISION, diff = rd->point - rd->lower;
    if (diff >= scale << PRECISION)
        return -1;
    uint32_t s = bits == 1 ? (uint32_t)(diff >= scale << shift) : (uint32_t)(diff / scale) >> shift;
    advance(rd, scale, s << shift, (uint32_t)1 << shift);
    *symbol = s;
    return 0;
}

int mrt_range_maybe_exhausted(const mrt_range_decoder *rd)
{
    const uint64_t max_difference = ((uint64_t)1 << 33) - 1;
    return rd->pos >= rd->words && (rd->range == UINT64_MAX || rd->point - rd->lower < max_difference);
}

/* ---- the models (motionrep.plugin.coding.Model, quantised as constriction's Categorical(perfect=False)) ---- */

static double zero_probability(int index)
{
    double o = ldexp(8 + index % 8, index / 8 - 19);
    return o / (1.0 + o);
}

static double decay_of(int index)
{
    double o = ldexp(4 + index % 4, index / 4 - 18);
    return o / (1.0 + o);
}

void mrt_model_build(int zero, int decay, mrt_model *m)
{
    double p[MRT_TOKENS];
    double theta = decay_of(decay), z = zero_probability(zero);
    double c = 1.0 - theta, t = 1.0;
    p[0] = z;
    for (int a = 1; a < DIRECT; a++) {
        p[a] = (1.0 - z) * (c * t);
        t = t * theta;
    }
    double power = theta;  /* theta ** (2 ** k), by squaring */
    for (int k = 0; k < FIRST_BUCKET; k++)
        power = power * power;
    double low = power / theta;  /* theta ** (2 ** 4 - 1) */
    for (int e = FIRST_BUCKET; e < MRT_TOKENS - DIRECT + FIRST_BUCKET; e++) {
        power = power * power;
        double high = power / theta;
        p[DIRECT + e - FIRST_BUCKET] = (1.0 - z) * (low - high);
        low = high;
    }
    /* constriction's fast quantisation: one unit of weight per token, the rest in proportion, left-cumulative */
    double normalization = 0.0;
    for (int k = 0; k < MRT_TOKENS; k++)
        normalization = normalization + p[k];
    double scale = (double)(((uint32_t)1 << PRECISION) - MRT_TOKENS) / normalization;
    double cumulative = 0.0;
    for (int k = 0; k < MRT_TOKENS; k++) {
        m->left[k] = (uint32_t)(cumulative * scale) + (uint32_t)k;
        cumulative = cumulative + p[k];
    }
    m->left[MRT_TOKENS] = (uint32_t)1 << PRECISION;
}

/* ---- integers (motionrep.plugin.coding.IntegerDecoder) -------------------------------------------------------- */

/* `count` unsigned fields of `bits` bits (1..62): chunks of 16 bits, the low chunk of every field first */
static int decode_raw(mrt_range_decoder *rd, size_t count, int bits, uint64_t *out, mrt_status *st)
{
    for (size_t i = 0; i < count; i++)
        out[i] = 0;
    for (int shift = 0; shift < bits; shift += CHUNK) {
        int width = bits - shift < CHUNK ? bits - shift : CHUNK;
        for (size_t i = 0; i < count; i++) {
            uint32_t s;
            if (mrt_range_uniform(rd, width, &s))
                return fail(st, MRT_DAMAGED, "%s", INVALID);
            out[i] |= (uint64_t)s << shift;
        }
    }
    return MRT_OK;
}

static int decode_field(mrt_range_decoder *rd, int bits, uint64_t *out, mrt_status *st)
{
    return decode_raw(rd, 1, bits, out, st);
}

/* `count` integers under `m`: the k-th into out[at[k]] (out[k] without `at`).  The tokens, then the signs of the
 * non-zero ones, then the low bits of the large ones: for each bit length in ascending order, every such value's
 * low 16 bits, then the next 16, ... (motionrep.plugin.coding.IntegerDecoder.decode) */
static int decode_integers_at(mrt_range_decoder *rd, const mrt_model *m, size_t count, int64_t *out,
                              const uint32_t *at, mrt_status *st)
{
#define AT(k) (at ? at[k] : (k))
    size_t big = 0, per_token[MRT_TOKENS] = {0};
    for (size_t k = 0; k < count; k++) {
        int s;
        if (range_symbol(rd, m, &s))
            return fail(st, MRT_DAMAGED, "%s", INVALID);
        out[AT(k)] = s;
        per_token[s]++;
    }
    if (per_token[0] < count) {
        for (size_t k = 0; k < count; k++) {
            int64_t *v = out + AT(k);
            if (*v == 0)
                continue;
            uint32_t negative;
            if (mrt_range_uniform(rd, 1, &negative))
                return fail(st, MRT_DAMAGED, "%s", INVALID);
            if (negative)
                *v = -*v;
        }
    }
    for (int token = DIRECT; token < MRT_TOKENS; token++)
        big += per_token[token];
    if (!big)
        return MRT_OK;
    size_t *where = malloc(big * sizeof *where);
    uint64_t *low = calloc(big, sizeof *low);
    if (!where || !low) {
        free(where);
        free(low);
        return fail(st, MRT_NO_MEMORY, "out of memory");
    }
    size_t start[MRT_TOKENS + 1] = {0};  /* the large values' positions, grouped by token (a counting sort) */
    for (int token = DIRECT; token < MRT_TOKENS; token++)
        start[token + 1] = start[token] + per_token[token];
    size_t fill[MRT_TOKENS];
    memcpy(fill, start, sizeof fill);
    for (size_t k = 0; k < count; k++) {
        int64_t v = out[AT(k)], a = v < 0 ? -v : v;
        if (a >= DIRECT)
            where[fill[a]++] = AT(k);
    }
#undef AT
    for (int token = DIRECT; token < MRT_TOKENS; token++) {
        int bits = token - DIRECT + FIRST_BUCKET;
        for (int shift = 0; per_token[token] && shift < bits; shift += CHUNK) {
            int width = bits - shift < CHUNK ? bits - shift : CHUNK;
            for (size_t k = start[token]; k < start[token + 1]; k++) {
                uint32_t s;
                if (mrt_range_uniform(rd, width, &s)) {
                    free(where);
                    free(low);
                    return fail(st, MRT_DAMAGED, "%s", INVALID);
                }
                low[k] |= (uint64_t)s << shift;
            }
        }
        for (size_t k = start[token]; k < start[token + 1]; k++) {
            int64_t a = (int64_t)(((uint64_t)1 << bits) + low[k]);
            out[where[k]] = out[where[k]] < 0 ? -a : a;
        }
    }
    free(where);
    free(low);
    return MRT_OK;
}

int mrt_decode_integers(mrt_range_decoder *rd, const mrt_model *m, size_t count, int64_t *out, mrt_status *st)
{
    return decode_integers_at(rd, m, count, out, NULL, st);
}

static int decode_models(mrt_range_decoder *rd, size_t count, mrt_model *models, int *zeros, mrt_status *st)
{
    /* two raw bytes each (zero index, decay index); all read before any is checked */
    uint64_t pair[2 * CONTEXTS];
    if (count > CONTEXTS)
        return fail(st, MRT_ARGUMENT, "too many models");
    if (decode_raw(rd, 2 * count, 8, pair, st))
        return st->code;
    for (size_t k = 0; k < count; k++)
        zeros[k] = (int)pair[2 * k];
    for (size_t k = 0; k < count; k++)
        if (pair[2 * k] > MRT_MAX_ZERO)
            return fail(st, MRT_DAMAGED, "transform payload: a stored model is out of range (damaged data)");
    for (size_t k = 0; k < count; k++)
        mrt_model_build((int)pair[2 * k], (int)pair[2 * k + 1], &models[k]);
    return MRT_OK;
}

uint64_t mrt_max_values(uint64_t bytes)
{
    return (uint64_t)ceil((double)(8 * bytes + 64) * PER_BIT);
}

/* numpy's abs of an int64 (the most negative value stays negative) */
static inline int64_t abs64(int64_t v)
{
    return v < 0 ? (int64_t)(0 - (uint64_t)v) : v;
}

/* a vector of step exponents: the first zigzag-coded in 16 raw bits, then the differences under a stored model */
static int decode_exponents(mrt_range_decoder *rd, uint64_t n, int64_t *v, mrt_status *st)
{
    uint64_t z;
    mrt_model model;
    int zero;
    if (decode_field(rd, 16, &z, st) || decode_models(rd, 1, &model, &zero, st))
        return st->code;
    v[0] = z % 2 == 0 ? (int64_t)(z / 2) : -(int64_t)((z + 1) / 2);
    if (n > 1 && mrt_decode_integers(rd, &model, n - 1, v + 1, st))
        return st->code;
    for (uint64_t i = 1; i < n; i++)  /* a running sum, wrapping as numpy's int64 cumsum */
        v[i] = (int64_t)((uint64_t)v[i - 1] + (uint64_t)v[i]);
    for (uint64_t i = 0; i < n; i++)
        if (abs64(v[i]) > MRT_MAX_EXPONENT || v[i] == INT64_MIN)
            return fail(st, MRT_DAMAGED, "transform payload: a step exponent is out of range");
    return MRT_OK;
}

int mrt_levels(uint64_t frames, uint64_t *sizes)
{
    int levels = 0;
    uint64_t n = frames, details[MRT_MAX_LEVELS];
    while (n >= 4 && levels < MRT_MAX_LEVELS) {
        details[levels++] = n / 2;
        n = (n + 1) / 2;
    }
    sizes[0] = n;
    for (int l = 0; l < levels; l++)
        sizes[1 + l] = details[levels - 1 - l];
    return levels;
}

int mrt_declared(const uint8_t *data, size_t size, int version, uint64_t *frames, uint64_t *features,
                 uint64_t *region_frames, mrt_status *st)
{
    mrt_range_decoder rd;
    ok(st);
    if (version == 2 || version == 3) {
        int64_t F, D, region;
        int e = mrc_declared(data, size, &F, &D, &region);
        if (e)
            return fail(st, MRT_DAMAGED, "transform payload (version %d): %s", version, mrc_error_text(e));
        *frames = (uint64_t)F;
        *features = (uint64_t)D;
        *region_frames = (uint64_t)region;
        return MRT_OK;
    }
    if (version != 1)
        return fail(st, MRT_VERSION, "transform payload: format version %d is not known to this decoder", version);
    if (size % 4)
        return fail(st, MRT_DAMAGED, "coded integers must be whole 32-bit words, got %zu bytes", size);
    mrt_range_init(&rd, data, size);
    if (decode_field(&rd, 32, frames, st) || decode_field(&rd, 20, features, st)
        || decode_field(&rd, 16, region_frames, st))
        return st->code;
    *frames += 1;
    *features += 1;
    *region_frames += 1;
    return MRT_OK;
}

void mrt_quantised_free(mrt_quantised *q)
{
    free(q->feature_exponents);
    free(q->region_exponents);
    free(q->coefficients);
    q->feature_exponents = q->region_exponents = q->coefficients = NULL;
}

/* bits of a context sum (0 for a sum <= 0), capped at SIZES - 1: comparisons, so the loops vectorise */
static inline uint8_t size_class(int64_t s)
{
    return (uint8_t)((s >= 1) + (s >= 2) + (s >= 4) + (s >= 8) + (s >= 16) + (s >= 32) + (s >= 64));
}

/* Where the parser puts coefficient (row, feature c) of a level: base[row * rs + c * cs].  Row-major for
 * mrt_unpack (rs = D, cs = 1); feature-major for mrt_decode (rs = 1, cs = F), where the coefficients are then
 * dequantised and transformed in place, one feature after the other. */
typedef struct {
    int64_t *base;
    uint64_t rs, cs;
} level_at;

/* scratch of the parser */
typedef struct {
    int64_t *steps;    /* the approximation's steps |A[i + 1] - A[i]|, the last repeated: (D, n0) */
    int64_t *pad_a;    /* a column of the coarser level's magnitudes between two zeros */
    int64_t *pad_e;    /* a column of this level's even magnitudes, a zero after */
    uint8_t *ctx;      /* one pass's contexts, (D, rows) */
    uint32_t *order;   /* one pass's coefficients grouped by context: where each goes */
} scratch;

/* One pass over a detail level (its even or its odd rows): each coefficient's context from what is decoded around
 * it (2 p + p_left + p_right of its parent row in the coarser level `above`, plus, in the odd pass, 2 (|e_left| +
 * |e_right|) of its even neighbours; sums wrap as numpy's int64), then the coefficients grouped by context
 * (ascending; row-major within each), each group under its context's model. */
MRT_CLONES
static int decode_pass(mrt_range_decoder *rd, const mrt_model *models, const int *have, uint64_t D, uint64_t n,
                       int odd, int group, level_at above, uint64_t arows, int magnitudes, level_at lv, scratch *w,
                       mrt_status *st)
{
    uint64_t rows = odd ? n / 2 : (n + 1) / 2, evens = (n + 1) / 2;
    uint8_t base = (uint8_t)((group * 2 + odd) * SIZES);
    int64_t *MRT_RESTRICT pa = w->pad_a, *MRT_RESTRICT pe = w->pad_e;
    for (uint64_t c = 0; c < D; c++) {
        const int64_t *ac = above.base + c * above.cs;
        pa[0] = 0;
        pa[arows + 1] = 0;
        if (magnitudes)
            for (uint64_t t = 0; t < arows; t++)
                pa[t + 1] = ac[t * above.rs];
        else
            for (uint64_t t = 0; t < arows; t++)
                pa[t + 1] = abs64(ac[t * above.rs]);
        uint8_t *MRT_RESTRICT cx = w->ctx + c * rows;
        if (odd) {
            const int64_t *lc = lv.base + c * lv.cs;
            for (uint64_t t = 0; t < evens; t++)
                pe[t] = abs64(lc[2 * t * lv.rs]);
            pe[evens] = 0;
            for (uint64_t r = 0; r < rows; r++) {
                uint64_t at = magnitudes ? 2 * r + 1 : r;
                at = at < arows - 1 ? at : arows - 1;
                uint64_t s = 2 * (uint64_t)pa[at + 1] + (uint64_t)pa[at] + (uint64_t)pa[at + 2]
                             + 2 * ((uint64_t)pe[r] + (uint64_t)pe[r + 1]);
                cx[r] = base + size_class((int64_t)s);
            }
        } else {
            for (uint64_t r = 0; r < rows; r++) {
                uint64_t at = magnitudes ? 2 * r : r;
                at = at < arows - 1 ? at : arows - 1;
                uint64_t s = 2 * (uint64_t)pa[at + 1] + (uint64_t)pa[at] + (uint64_t)pa[at + 2];
                cx[r] = base + size_class((int64_t)s);
            }
        }
    }
    uint64_t m = rows * D, counts[4][SIZES] = {{0}};
    const uint8_t *ctx = w->ctx;
    uint64_t p = 0;
    for (; p + 4 <= m; p += 4) {  /* four histograms: no store waits for the one before */
        counts[0][ctx[p] - base]++;
        counts[1][ctx[p + 1] - base]++;
        counts[2][ctx[p + 2] - base]++;
        counts[3][ctx[p + 3] - base]++;
    }
    for (; p < m; p++)
        counts[0][ctx[p] - base]++;
    uint64_t start[SIZES + 1], fill[SIZES];
    start[0] = 0;
    for (int k = 0; k < SIZES; k++)
        start[k + 1] = start[k] + counts[0][k] + counts[1][k] + counts[2][k] + counts[3][k];
    memcpy(fill, start, sizeof fill);
    for (uint64_t r = 0; r < rows; r++) {  /* each group's coefficients, row-major */
        uint64_t row = (odd + 2 * r) * lv.rs;
        for (uint64_t c = 0; c < D; c++)
            w->order[fill[ctx[c * rows + r] - base]++] = (uint32_t)(row + c * lv.cs);
    }
    for (int k = 0; k < SIZES; k++) {
        uint64_t count = start[k + 1] - start[k];
        if (!count)
            continue;
        if (!have[base + k])
            return fail(st, MRT_DAMAGED,
                        "transform payload: a coefficient's context has no stored model (damaged data)");
        if (decode_integers_at(rd, &models[base + k], count, lv.base, w->order + start[k], st))
            return st->code;
    }
    return MRT_OK;
}

/* q's counts for F frames and D features in regions of `region` frames (accepted against the payload's size), its
 * exponent arrays allocated, and its coefficients' too with `coefficients` */
static int head_into(mrt_quantised *q, uint64_t F, uint64_t D, uint64_t region, int coefficients, mrt_status *st)
{
    q->frames = F;
    q->features = D;
    q->region_frames = region;
    q->regions = (F + region - 1) / region;
    q->levels = mrt_levels(F, q->sizes);
    q->feature_exponents = malloc(D * sizeof(int64_t));
    q->region_exponents = malloc(q->regions * sizeof(int64_t));
    if (coefficients)
        q->coefficients = malloc(F * D * sizeof(int64_t));
    if (!q->feature_exponents || !q->region_exponents || (coefficients && !q->coefficients))
        return fail(st, MRT_NO_MEMORY, "out of memory");
    return MRT_OK;
}

/* The head of a version-1 payload: counts (checked against what the bytes can hold), step exponents. */
static int parse_head_v1(mrt_range_decoder *rd, size_t size, mrt_quantised *q, mrt_status *st)
{
    uint64_t F = 0, D = 0, region = 0;
    if (decode_field(rd, 32, &F, st) || decode_field(rd, 20, &D, st) || decode_field(rd, 16, &region, st))
        return st->code;
    F += 1;
    D += 1;
    region += 1;
    uint64_t regions = (F + region - 1) / region;
    if (F * D + D + regions > mrt_max_values(size))
        return fail(st, MRT_DAMAGED, "transform payload: %llu frames x %llu features cannot be held in %zu bytes "
                    "(damaged data)", (unsigned long long)F, (unsigned long long)D, size);
    if (head_into(q, F, D, region, 0, st))
        return st->code;
    if (decode_exponents(rd, D, q->feature_exponents, st) || decode_exponents(rd, regions, q->region_exponents, st))
        return st->code;
    if (F * D > UINT32_MAX)  /* more than 32 GiB of coefficients: no machine holds them */
        return fail(st, MRT_NO_MEMORY, "out of memory");
    return MRT_OK;
}

/* The coefficients of a version-1 payload after its head: the context models, the approximation, then each detail
 * level coarse to fine in two passes; every coefficient of the clip is written (or an error returned). */
static int parse_coefficients_v1(mrt_range_decoder *rd, const mrt_quantised *q, int64_t *coef, int feature_major,
                                 mrt_status *st)
{
    uint64_t F = q->frames, D = q->features, n0 = q->sizes[0];
    uint64_t rs = feature_major ? 1 : D, cs = feature_major ? F : 1;
    uint64_t bitmap;
    if (decode_field(rd, CONTEXTS, &bitmap, st))
        return st->code;
    mrt_model used_models[CONTEXTS], models[CONTEXTS], m_ends[2];
    int zeros[CONTEXTS], have[CONTEXTS] = {0}, which[CONTEXTS];
    size_t used = 0;
    for (int k = 0; k < CONTEXTS; k++)
        if (bitmap >> k & 1) {
            which[used++] = k;
            have[k] = 1;
        }
    if (decode_models(rd, used, used_models, zeros, st) || decode_models(rd, 2, m_ends, zeros, st))
        return st->code;
    for (size_t u = 0; u < used; u++)
        models[which[u]] = used_models[u];
    uint64_t largest = 0;
    for (int l = 1; l <= q->levels; l++)
        largest = q->sizes[l] > largest ? q->sizes[l] : largest;
    uint64_t orders = (largest + 1) / 2 * D > n0 * D ? (largest + 1) / 2 * D : n0 * D;
    scratch w;
    w.steps = malloc(n0 * D * sizeof(int64_t));
    w.pad_a = malloc((F + 2) * sizeof(int64_t));
    w.pad_e = malloc((F + 2) * sizeof(int64_t));
    w.ctx = malloc((largest + 1) / 2 * D + 1);
    w.order = malloc(orders * sizeof(uint32_t));
    int code = MRT_OK;
    if (!w.steps || !w.pad_a || !w.pad_e || !w.ctx || !w.order) {
        code = fail(st, MRT_NO_MEMORY, "out of memory");
        goto done;
    }
    /* the approximation: its first row, then the differences of the next rows, summed down each column (wrapping) */
    for (uint64_t k = 0; k < n0 * D; k++)
        w.order[k] = (uint32_t)(k / D * rs + k % D * cs);
    if (decode_integers_at(rd, &m_ends[0], D, coef, w.order, st)
        || decode_integers_at(rd, &m_ends[1], (n0 - 1) * D, coef, w.order + D, st)) {
        code = st->code;
        goto done;
    }
    for (uint64_t c = 0; c < D; c++) {
        int64_t *a = coef + c * cs;
        for (uint64_t i = 1; i < n0; i++)
            a[i * rs] = (int64_t)((uint64_t)a[(i - 1) * rs] + (uint64_t)a[i * rs]);
        for (uint64_t i = 0; q->levels && i < n0; i++) {
            uint64_t r = i + 1 < n0 ? i : n0 - 2;
            w.steps[c * n0 + i] = abs64((int64_t)((uint64_t)a[(r + 1) * rs] - (uint64_t)a[r * rs]));
        }
    }
    uint64_t offset = n0;  /* the level's first row */
    for (int index = 1; index <= q->levels && code == MRT_OK; index++) {
        int j = q->levels - index + 1;
        uint64_t n = q->sizes[index], arows = index == 1 ? n0 : q->sizes[index - 1];
        level_at above = index == 1 ? (level_at){w.steps, 1, n0} : (level_at){coef + (offset - arows) * rs, rs, cs};
        level_at lv = {coef + offset * rs, rs, cs};
        for (int odd = 0; odd < 2 && code == MRT_OK; odd++)
            code = decode_pass(rd, models, have, D, n, odd, j <= FINE, above, arows, index == 1, lv, &w, st);
        offset += n;
    }
done:
    free(w.steps);
    free(w.pad_a);
    free(w.pad_e);
    free(w.ctx);
    free(w.order);
    return code;
}

static int begin(const uint8_t *data, size_t size, int version, mrt_range_decoder *rd, mrt_quantised *q,
                 mrt_status *st)
{
    memset(q, 0, sizeof *q);
    ok(st);
    if (version != 1)
        return fail(st, MRT_VERSION, "transform payload: format version %d is not known to this decoder", version);
    if (size % 4)
        return fail(st, MRT_DAMAGED, "coded integers must be whole 32-bit words, got %zu bytes", size);
    mrt_range_init(rd, data, size);
    return parse_head_v1(rd, size, q, st);
}

static int finish(const mrt_range_decoder *rd, mrt_status *st)
{
    if (!mrt_range_maybe_exhausted(rd))
        return fail(st, MRT_DAMAGED, "coded integers are damaged (data left over after the last value)");
    return MRT_OK;
}

/* A version-2 or version-3 payload: its integers decoded by mrcoder.c (the adaptive coder of specs/codecs.md,
 * "Payload version 2" and "Payload version 3"), after its counts are checked against its bytes: row-major into q
 * (q->coefficients), or, with `feature_major`
 * (mrt_decode), feature-major into a buffer of F x D int64 allocated here (*buffer, which mrt_decode dequantises and
 * transforms back in place, as version 1's). */
static int unpack_v2(const uint8_t *data, size_t size, int version, mrt_quantised *q, int64_t **buffer,
                     mrt_status *st)
{
    uint64_t F = 0, D = 0, region = 0;
    if (mrt_declared(data, size, version, &F, &D, &region, st))
        return st->code;
    uint64_t regions = (F + region - 1) / region;
    if (F * D + D + regions > (uint64_t)MRC_VALUES_PER_BYTE * size)  /* before anything is allocated */
        return fail(st, MRT_DAMAGED, "transform payload (version %d): %llu frames x %llu features cannot be held in "
                    "%zu bytes (damaged data)", version, (unsigned long long)F, (unsigned long long)D, size);
    if (head_into(q, F, D, region, !buffer, st))
        return st->code;
    if (buffer && !(*buffer = malloc(F * D * sizeof(int64_t))))
        return fail(st, MRT_NO_MEMORY, "out of memory");
    int e = mrc_decode_version(version, data, size, q->feature_exponents, q->region_exponents,
                               buffer ? *buffer : q->coefficients, buffer != NULL);
    if (e == MRC_E_MEMORY)
        return fail(st, MRT_NO_MEMORY, "out of memory");
    if (e)
        return fail(st, MRT_DAMAGED, "transform payload (version %d): %s", version, mrc_error_text(e));
    return MRT_OK;
}

int mrt_unpack(const uint8_t *data, size_t size, int version, mrt_quantised *q, mrt_status *st)
{
    mrt_range_decoder rd;
    if (version == 2 || version == 3) {
        memset(q, 0, sizeof *q);
        ok(st);
        return unpack_v2(data, size, version, q, NULL, st);
    }
    if (begin(data, size, version, &rd, q, st))
        return st->code;
    if (!(q->coefficients = malloc(q->frames * q->features * sizeof(int64_t))))
        return fail(st, MRT_NO_MEMORY, "out of memory");
    if (parse_coefficients_v1(&rd, q, q->coefficients, 0, st))
        return st->code;
    return finish(&rd, st);
}

/* ---- dequantisation and the inverse wavelet ------------------------------------------------------------------ */

void mrt_frames_free(mrt_frames *f)
{
    free(f->values);
    free(f->rows);
    f->values = f->rows = NULL;
}

int mrt_frames_rows(mrt_frames *f)
{
    uint64_t F = f->frames, D = f->features;
    if (f->rows)
        return MRT_OK;
    if (!(f->rows = malloc((F * D > 0 ? F * D : 1) * sizeof(double))))
        return MRT_NO_MEMORY;
    for (uint64_t i0 = 0; i0 < F; i0 += 8)  /* eight frames at a time: contiguous reads and writes */
        for (uint64_t d = 0; d < D; d++)
            for (uint64_t i = i0; i < i0 + 8 && i < F; i++)
                f->rows[i * D + d] = f->values[d * F + i];
    return MRT_OK;
}

/* out[i] = min(v[max(0, i - span) .. min(n - 1, i + span)]): scipy's minimum_filter1d(v, 2 span + 1,
 * mode="nearest"), as motionrep_transform._codec.window_minimum; a monotonic queue, O(n) */
static void window_minimum(const int64_t *v, uint64_t n, uint64_t span, int64_t *out, uint64_t *queue)
{
    uint64_t head = 0, tail = 0, next = 0;  /* queue[head..tail): indices of increasing values */
    for (uint64_t i = 0; i < n; i++) {
        uint64_t hi = span >= n - 1 - i ? n - 1 : i + span;
        for (; next <= hi; next++) {
            while (tail > head && v[queue[tail - 1]] >= v[next])
                tail--;
            queue[tail++] = next;
        }
        uint64_t lo = i > span ? i - span : 0;
        while (queue[head] < lo)
            head++;
        out[i] = v[queue[head]];
    }
}

static inline int64_t floor_div8(int64_t i)
{
    return i >= 0 ? i / 8 : -((-i + 7) / 8);
}

/* One level of the inverse wavelet's lifting steps on s (ns) and d (nd), s and d already scaled: the operations of
 * motionrep_transform's numpy inverse, in its order: d -= a (s + s_right) or s -= a (d_left + d_here), last step
 * first. */
static inline __attribute__((always_inline)) void lift(double *MRT_RESTRICT s, double *MRT_RESTRICT d, uint64_t ns,
                                                       uint64_t nd)
{
    for (int k = 3; k >= 0; k--) {
        double a = STEPS[k];
        if (k % 2 == 0) {  /* d[i] -= a (s[i] + s[min(i + 1, ns - 1)]) */
            uint64_t inner = ns > nd ? nd : nd - 1;
            for (uint64_t i = 0; i < inner; i++)
                d[i] = d[i] - a * (s[i] + s[i + 1]);
            if (inner < nd)
                d[nd - 1] = d[nd - 1] - a * (s[nd - 1] + s[ns - 1]);
        } else {  /* s[i] -= a (d[max(i - 1, 0)] + d[min(i, nd - 1)]) */
            s[0] = s[0] - a * (d[0] + d[0]);
            for (uint64_t i = 1; i < nd; i++)
                s[i] = s[i] - a * (d[i - 1] + d[i]);
            if (ns > nd)
                s[nd] = s[nd] - a * (d[nd - 1] + d[nd - 1]);
        }
    }
}

/* The inverse wavelet: the lifting steps of one feature's samples x (the storage order: approximation, detail L,
 * ..., detail 1) back to the signal, in place; tmp holds as many doubles as x.  The operations of
 * motionrep_transform's numpy inverse, in its order: s and d scaled, then lift's steps. */
MRT_CLONES
void mrt_inverse(double *x, const uint64_t *sizes, int levels, double *tmp)
{
    uint64_t ns = sizes[0];
    for (int l = 1; l <= levels; l++) {
        uint64_t nd = sizes[l];
        double *MRT_RESTRICT s = tmp, *MRT_RESTRICT d = tmp + ns;
        for (uint64_t i = 0; i < ns; i++)
            s[i] = x[i] / LOW;
        for (uint64_t i = 0; i < nd; i++)
            d[i] = x[ns + i] / HIGH;
        lift(s, d, ns, nd);
        for (uint64_t i = 0; i < nd; i++) {
            x[2 * i] = s[i];
            x[2 * i + 1] = d[i];
        }
        if (ns > nd)
            x[2 * nd] = s[nd];
        ns += nd;
    }
}

/* the int64 at x[i] of a buffer that holds int64 and doubles (mrt_decode's, in place) */
static inline int64_t int_at(const double *x, uint64_t i)
{
    int64_t v;
    memcpy(&v, x + i, sizeof v);
    return v;
}

/* o[i] = (coefficient v[i] x its step) / scale, the coefficients the int64 at v[0..n) (rows first..first + n of the
 * column, their steps steps[krow[row]]); `skip`: the steps are finite, so that a zero coefficient gives +0.0 (0 x
 * step / scale) without the operations, which are then done for the non-zero ones only */
static inline __attribute__((always_inline)) void dequantised(const double *v, uint64_t n, const double *steps,
                                                              const int64_t *krow, double scale, int skip,
                                                              double *MRT_RESTRICT o)
{
    uint64_t i0 = 0;
    for (; skip && i0 + 8 <= n; i0 += 8) {  /* eight at a time: most details are zero */
        int64_t any = 0;
        for (int k = 0; k < 8; k++)
            any |= int_at(v, i0 + k);
        if (!any) {
            for (int k = 0; k < 8; k++)
                o[i0 + k] = 0.0;
            continue;
        }
        for (int k = 0; k < 8; k++) {
            int64_t c = int_at(v, i0 + k);
            o[i0 + k] = c ? (double)c * steps[krow[i0 + k]] / scale : 0.0;
        }
    }
    for (; i0 < n; i0++)
        o[i0] = (double)int_at(v, i0) * steps[krow[i0]] / scale;
}

/* One feature's column: the quantised coefficients x[0..F) (int64, storage order) dequantised (coefficient x step)
 * and transformed back (mrt_inverse's operations) into the doubles x[0..F), in place.  Each value gets the
 * operations it gets in the dequantisation then mrt_inverse (the same bits), fused: each level's samples are
 * scaled for the next level as they are interleaved (s / LOW), and the details are dequantised and scaled in one
 * (coefficient x step / HIGH); tmp holds 2 F doubles. */
static inline __attribute__((always_inline)) void synthesise_column(double *x, const uint64_t *sizes, int levels,
                                                                    const double *steps, const int64_t *krow,
                                                                    int skip, double *tmp)
{
    uint64_t ns = sizes[0], F = ns;
    for (int l = 1; l <= levels; l++)
        F += sizes[l];
    if (!levels) {
        dequantised(x, ns, steps, krow, 1.0, 0, tmp);  /* x step / 1: x step exactly */
        memcpy(x, tmp, ns * sizeof *x);
        return;
    }
    double *cur = tmp, *next = tmp + F;
    dequantised(x, ns, steps, krow, LOW, 0, cur);
    for (int l = 1; l <= levels; l++) {
        uint64_t nd = sizes[l];
        double *MRT_RESTRICT s = cur, *MRT_RESTRICT d = cur + ns;
        dequantised(x + ns, nd, steps, krow + ns, HIGH, skip, d);
        lift(s, d, ns, nd);
        if (l == levels) {
            for (uint64_t i = 0; i < nd; i++) {
                x[2 * i] = s[i];
                x[2 * i + 1] = d[i];
            }
            if (ns > nd)
                x[2 * nd] = s[nd];
        } else {  /* the next level's s: these samples / LOW */
            double *MRT_RESTRICT o = next;
            for (uint64_t i = 0; i < nd; i++) {
                o[2 * i] = s[i] / LOW;
                o[2 * i + 1] = d[i] / LOW;
            }
            if (ns > nd)
                o[2 * nd] = s[nd] / LOW;
            next = cur;
            cur = o;
        }
        ns += nd;
    }
}

#if defined(__GNUC__)
#define MRT_BLOCK 8
typedef double mrt_v8 __attribute__((vector_size(64)));

/* lift's steps on eight features at once (s and d: one vector of the eight features per sample): each lane gets
 * the operations lift gives its feature, in the same order */
static inline __attribute__((always_inline)) void lift8(mrt_v8 *MRT_RESTRICT s, mrt_v8 *MRT_RESTRICT d, uint64_t ns,
                                                        uint64_t nd)
{
    for (int k = 3; k >= 0; k--) {
        mrt_v8 a = {STEPS[k], STEPS[k], STEPS[k], STEPS[k], STEPS[k], STEPS[k], STEPS[k], STEPS[k]};
        if (k % 2 == 0) {
            uint64_t inner = ns > nd ? nd : nd - 1;
            for (uint64_t i = 0; i < inner; i++)
                d[i] = d[i] - a * (s[i] + s[i + 1]);
            if (inner < nd)
                d[nd - 1] = d[nd - 1] - a * (s[nd - 1] + s[ns - 1]);
        } else {
            s[0] = s[0] - a * (d[0] + d[0]);
            for (uint64_t i = 1; i < nd; i++)
                s[i] = s[i] - a * (d[i - 1] + d[i]);
            if (ns > nd)
                s[nd] = s[nd] - a * (d[nd - 1] + d[nd - 1]);
        }
    }
}

/* dequantised's values of rows first..first + n of eight columns x[0..7] (each with its steps), one vector a row */
static inline __attribute__((always_inline)) void dequantised8(double *const *x, uint64_t first, uint64_t n,
                                                               const double *const *steps, const int64_t *krow,
                                                               double scale, int skip, mrt_v8 *MRT_RESTRICT o)
{
    for (uint64_t i = 0; i < n; i++) {
        int64_t c[8], any = 0;
        for (int k = 0; k < 8; k++) {
            c[k] = int_at(x[k], first + i);
            any |= c[k];
        }
        if (skip && !any) {
            o[i] = (mrt_v8){0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
            continue;
        }
        mrt_v8 v;
        for (int k = 0; k < 8; k++)
            v[k] = skip && !c[k] ? 0.0 : (double)c[k] * steps[k][krow[first + i]] / scale;
        o[i] = v;
    }
}

/* synthesise_column for eight columns x[0..7] at once (every lane the operations of its column, so the same bits);
 * tmp holds 2 F vectors */
static inline __attribute__((always_inline)) void synthesise_block(double *const *x, const uint64_t *sizes,
                                                                   int levels, const double *const *steps,
                                                                   const int64_t *krow, int skip, mrt_v8 *tmp)
{
    uint64_t ns = sizes[0], F = ns;
    for (int l = 1; l <= levels; l++)
        F += sizes[l];
    mrt_v8 *cur = tmp, *next = tmp + F;
    if (!levels) {
        dequantised8(x, 0, ns, steps, krow, 1.0, 0, cur);
        for (uint64_t i = 0; i < ns; i++)
            for (int k = 0; k < 8; k++)
                x[k][i] = cur[i][k];
        return;
    }
    dequantised8(x, 0, ns, steps, krow, LOW, 0, cur);
    for (int l = 1; l <= levels; l++) {
        uint64_t nd = sizes[l];
        mrt_v8 *MRT_RESTRICT s = cur, *MRT_RESTRICT d = cur + ns;
        dequantised8(x, ns, nd, steps, krow, HIGH, skip, d);
        lift8(s, d, ns, nd);
        if (l == levels) {
            for (uint64_t i = 0; i < nd; i++)
                for (int k = 0; k < 8; k++) {
                    x[k][2 * i] = s[i][k];
                    x[k][2 * i + 1] = d[i][k];
                }
            if (ns > nd)
                for (int k = 0; k < 8; k++)
                    x[k][2 * nd] = s[nd][k];
        } else {
            mrt_v8 *MRT_RESTRICT o = next;
            mrt_v8 low = {LOW, LOW, LOW, LOW, LOW, LOW, LOW, LOW};
            for (uint64_t i = 0; i < nd; i++) {
                o[2 * i] = s[i] / low;
                o[2 * i + 1] = d[i] / low;
            }
            if (ns > nd)
                o[2 * nd] = s[nd] / low;
            next = cur;
            cur = o;
        }
        ns += nd;
    }
}
#endif

/* The forward transform of one signal x (in place: [approximation, detail L, ..., detail 1], as mrt_inverse reads
 * them; tmp holds sizes' total): the encoder's analysis, not used by decoding.  The lifting steps of
 * _wavelet.forward, operation for operation (d[i] + a (s[i] + s[min(i + 1, ns - 1)]), s[i] + a (d[max(i - 1, 0)] +
 * d[min(i, nd - 1)]), then the subbands scaled): the numpy forward's bits. */
MRT_CLONES void mrt_forward(double *x, const uint64_t *sizes, int levels, double *tmp)
{
    uint64_t n = 0;
    for (int l = 0; l <= levels; l++)
        n += sizes[l];
    for (int l = levels; l >= 1; l--) {
        uint64_t nd = sizes[l], ns = n - nd;
        double *MRT_RESTRICT s = tmp, *MRT_RESTRICT d = tmp + ns;
        for (uint64_t i = 0; i < nd; i++) {
            s[i] = x[2 * i];
            d[i] = x[2 * i + 1];
        }
        if (ns > nd)
            s[nd] = x[2 * nd];
        for (int k = 0; k < 4; k++) { /* the ends peeled off (as lift's): the inner loops vectorise */
            double a = STEPS[k];
            if (k % 2 == 0) { /* d[i] += a (s[i] + s[min(i + 1, ns - 1)]) */
                uint64_t inner = ns > nd ? nd : nd - 1;
                for (uint64_t i = 0; i < inner; i++)
                    d[i] = d[i] + a * (s[i] + s[i + 1]);
                if (inner < nd)
                    d[nd - 1] = d[nd - 1] + a * (s[nd - 1] + s[ns - 1]);
            } else { /* s[i] += a (d[max(i - 1, 0)] + d[min(i, nd - 1)]) */
                s[0] = s[0] + a * (d[0] + d[0]);
                for (uint64_t i = 1; i < nd; i++)
                    s[i] = s[i] + a * (d[i - 1] + d[i]);
                if (ns > nd)
                    s[nd] = s[nd] + a * (d[nd - 1] + d[nd - 1]);
            }
        }
        for (uint64_t i = 0; i < ns; i++)
            x[i] = s[i] * LOW;
        for (uint64_t i = 0; i < nd; i++)
            x[ns + i] = d[i] * HIGH;
        n = ns;
    }
}

/* The steps of a quantised payload: `table` (2 ** (e / 8) for e = lo..hi, as motionrep.plugin.coding.step_scale)
 * and each coefficient row's region part of its exponent as an index into it (krow, F entries), the exponents
 * checked to be in range. */
static int step_tables(const mrt_quantised *q, double **table, int64_t *krow, int *finite, mrt_status *st)
{
    uint64_t F = q->frames, D = q->features, R = q->regions, sizes[MRT_MAX_LEVELS + 1];
    *table = NULL;
    if (F < 1 || D < 1 || q->region_frames < 1 || R != (F + q->region_frames - 1) / q->region_frames
        || mrt_levels(F, sizes) != q->levels || memcmp(sizes, q->sizes, (q->levels + 1) * sizeof *sizes))
        return fail(st, MRT_ARGUMENT, "transform payload: coefficient arrays do not fit the clip");
    int L = q->levels;
    int64_t fmin = INT64_MAX, fmax = INT64_MIN, kmin = INT64_MAX, kmax = INT64_MIN;
    for (uint64_t c = 0; c < D; c++) {
        fmin = q->feature_exponents[c] < fmin ? q->feature_exponents[c] : fmin;
        fmax = q->feature_exponents[c] > fmax ? q->feature_exponents[c] : fmax;
    }
    for (uint64_t r = 0; r < R; r++) {
        kmin = q->region_exponents[r] < kmin ? q->region_exponents[r] : kmin;
        kmax = q->region_exponents[r] > kmax ? q->region_exponents[r] : kmax;
    }
    const int64_t far = (int64_t)1 << 40;  /* beyond: out of range whatever the sums (and no sum wraps) */
    if (fmin < -far || fmax > far || kmin < -far || kmax > far)
        return fail(st, MRT_DAMAGED, "transform payload: a step is out of range");
    /* each array's window minima of the region exponents (the smallest within a coefficient's reach) */
    int64_t *k = malloc(((size_t)L + 1) * R * sizeof(int64_t));
    uint64_t *queue = malloc(R * sizeof(uint64_t));
    int code = MRT_OK;
    if (!k || !queue) {
        code = fail(st, MRT_NO_MEMORY, "out of memory");
        goto done;
    }
    for (int a = 0; a <= L; a++) {
        int span_level = a == 0 ? L : L - a + 1;
        uint64_t span = (uint64_t)ceil((double)((uint64_t)3 << span_level) / (double)q->region_frames);
        window_minimum(q->region_exponents, R, span, k + (size_t)a * R, queue);
    }
    /* each row's region part; the exponents k + f of its coefficients span [min k + min f, max k + max f] */
    int64_t lo = INT64_MAX, hi = INT64_MIN;
    uint64_t row = 0;
    for (int a = 0; a <= L; a++)
        for (uint64_t i = 0; i < q->sizes[a]; i++, row++) {
            uint64_t frame = a == 0 ? i << L : (2 * i + 1) << (L - a);
            frame = frame < F - 1 ? frame : F - 1;
            uint64_t r = frame / q->region_frames;
            int64_t v = k[(size_t)a * R + (r < R - 1 ? r : R - 1)];
            krow[row] = v;
            lo = v + fmin < lo ? v + fmin : lo;
            hi = v + fmax > hi ? v + fmax : hi;
        }
    if (lo < -MRT_MAX_EXPONENT || hi > MRT_MAX_EXPONENT) {
        code = fail(st, MRT_DAMAGED, "transform payload: a step is out of range");
        goto done;
    }
    if (!(*table = malloc((size_t)(hi - lo + 1) * sizeof(double)))) {
        code = fail(st, MRT_NO_MEMORY, "out of memory");
        goto done;
    }
    *finite = 1;
    for (int64_t e = lo; e <= hi; e++) {
        (*table)[e - lo] = ldexp(EIGHTH_ROOTS[e - 8 * floor_div8(e)], (int)floor_div8(e));
        *finite &= (*table)[e - lo] < INFINITY;
    }
    for (uint64_t r = 0; r < F; r++)
        krow[r] -= lo;
done:
    free(k);
    free(queue);
    return code;
}

/* Dequantise (coefficient x 2 ** (exponent / 8)) and transform back the feature columns of `values` (D, F), whose
 * coefficients are `coef` (row-major (F, D), or, with coef NULL, the int64 in `values` itself), then check that
 * every value is finite. */
MRT_CLONES
static int synthesise(const mrt_quantised *q, const int64_t *coef, double *values, mrt_status *st)
{
    uint64_t F = q->frames, D = q->features;
    int64_t *krow = malloc(F * sizeof(int64_t));
    double *table = NULL, *tmp = malloc(2 * F * sizeof(double));
    int finite_steps = 0;
#ifdef MRT_BLOCK
    /* (vectors aligned to their size: malloc's 16 bytes rounded up by hand, aligned_alloc being C11) */
    char *raw8 = D >= MRT_BLOCK ? malloc((2 * F + 1) * sizeof(mrt_v8)) : NULL;
    mrt_v8 *tmp8 = raw8 ? (mrt_v8 *)(void *)(raw8 + (sizeof(mrt_v8) - (uintptr_t)raw8 % sizeof(mrt_v8))
                                             % sizeof(mrt_v8)) : NULL;
#endif
    int code = !krow || !tmp ? fail(st, MRT_NO_MEMORY, "out of memory")
                             : step_tables(q, &table, krow, &finite_steps, st);
    if (code)
        goto done;
    if (coef) {  /* from row-major into the columns of values, as int64: eight rows at a time (contiguous stores) */
        for (uint64_t r0 = 0; r0 < F; r0 += 8) {
            uint64_t nb = F - r0 < 8 ? F - r0 : 8;
            for (uint64_t c = 0; c < D; c++) {
                const int64_t *from = coef + r0 * D + c;
                double *v = values + c * F + r0;
                for (uint64_t r = 0; r < nb; r++)
                    memcpy(v + r, from + r * D, sizeof *v);
            }
        }
    }
    int finite = 1;
#ifdef MRT_BLOCK
    double *block[MRT_BLOCK];  /* the columns that wait to be synthesised together, and their steps */
    const double *steps[MRT_BLOCK];
    int waiting = 0;
#endif
    for (uint64_t c = 0; c < D; c++) {
        double *x = values + c * F;
        /* all zero (from mrt_decode, or with finite steps): dequantised and transformed back, every value is +0.0,
         * the bytes it holds */
        if (!coef || finite_steps) {
            int64_t any = 0;
            for (uint64_t r = 0; r < F; r++)
                any |= int_at(x, r);
            if (!any)
                continue;
        }
#ifdef MRT_BLOCK
        if (tmp8) {  /* eight columns at a time */
            block[waiting] = x;
            steps[waiting++] = table + q->feature_exponents[c];
            if (waiting < MRT_BLOCK)
                continue;
            synthesise_block(block, q->sizes, q->levels, steps, krow, finite_steps, tmp8);
            waiting = 0;
            for (int k = 0; k < MRT_BLOCK; k++)
                for (uint64_t i = 0; i < F; i++)
                    finite &= fabs(block[k][i]) < INFINITY;
            continue;
        }
#endif
        synthesise_column(x, q->sizes, q->levels, table + q->feature_exponents[c], krow, finite_steps, tmp);
        for (uint64_t i = 0; i < F; i++)
            finite &= fabs(x[i]) < INFINITY;
    }
#ifdef MRT_BLOCK
    for (int k = 0; k < waiting; k++) {  /* the last few one by one */
        synthesise_column(block[k], q->sizes, q->levels, steps[k], krow, finite_steps, tmp);
        for (uint64_t i = 0; i < F; i++)
            finite &= fabs(block[k][i]) < INFINITY;
    }
#endif
    if (!finite)
        code = fail(st, MRT_DAMAGED, "transform payload: the coefficients decode to values that are not finite");
done:
    free(krow);
    free(tmp);
    free(table);
#ifdef MRT_BLOCK
    free(raw8);
#endif
    return code;
}

int mrt_reconstruct(const mrt_quantised *q, mrt_frames *out, mrt_status *st)
{
    memset(out, 0, sizeof *out);
    ok(st);
    uint64_t count = q->frames * q->features;
    double *values = malloc((count ? count : 1) * sizeof(double));
    if (!values)
        return fail(st, MRT_NO_MEMORY, "out of memory");
    if (synthesise(q, q->coefficients, values, st)) {
        free(values);
        return st->code;
    }
    out->frames = q->frames;
    out->features = q->features;
    out->values = values;
    return MRT_OK;
}

int mrt_decode(const uint8_t *data, size_t size, int version, mrt_frames *out, mrt_status *st)
{
    /* one buffer: the coefficients decoded feature-major into it (version 1 parsed here, versions 2 and 3 by
     * mrcoder.c),
     * then dequantised and transformed back in place */
    mrt_range_decoder rd;
    mrt_quantised q;
    memset(out, 0, sizeof *out);
    int64_t *buffer = NULL;
    int code;
    if (version == 2 || version == 3) {
        memset(&q, 0, sizeof q);
        ok(st);
        code = unpack_v2(data, size, version, &q, &buffer, st);
    } else {
        code = begin(data, size, version, &rd, &q, st);
        if (!code && !(buffer = malloc(q.frames * q.features * sizeof(int64_t))))
            code = fail(st, MRT_NO_MEMORY, "out of memory");
        if (!code)
            code = parse_coefficients_v1(&rd, &q, buffer, 1, st);
        if (!code)
            code = finish(&rd, st);
    }
    if (!code)
        code = synthesise(&q, NULL, (double *)(void *)buffer, st);
    if (!code) {
        out->frames = q.frames;
        out->features = q.features;
        out->values = (double *)(void *)buffer;
        buffer = NULL;
    }
    free(buffer);
    mrt_quantised_free(&q);
    return code;
}

/* ---- sampling ------------------------------------------------------------------------------------------------ */

/* frame j, its successor and the fraction between them of each time, as motionrep_transform's sampler (frame
 * indices below 2^32: F * D values fit in memory) */
static void positions(uint64_t F, const double *times, size_t count, int32_t *first, int32_t *second,
                      double *frac)
{
    for (size_t i = 0; i < count; i++) {
        double t = times[i];
        t = t != t ? 0.0 : t;  /* NaN: the first frame (never reaches here through motionrep) */
        t = 0.0 > t ? 0.0 : t;
        t = 1.0 < t ? 1.0 : t;
        uint64_t j = 0;
        double a = 0.0;
        if (F > 1) {
            double pos = t * (double)(F - 1);
            j = (uint64_t)floor(pos);
            j = j < F - 1 ? j : F - 1;
            a = pos - (double)j;
        }
        first[i] = (int32_t)j;
        second[i] = (int32_t)(j + 1 < F - 1 ? j + 1 : F - 1);
        frac[i] = a;
    }
}

/* o[i] = the value between r[j0[i]] and r[j1[i]] at fraction fr[i] (exactly r[j0[i]] at fraction 0) */
static inline void lerp_gather(const double *MRT_RESTRICT r, const int32_t *MRT_RESTRICT j0,
                               const int32_t *MRT_RESTRICT j1, const double *MRT_RESTRICT fr, double *MRT_RESTRICT o,
                               size_t m)
{
    for (size_t i = 0; i < m; i++) {
        double v = r[j0[i]], u = r[j1[i]];
        double w = v + (u - v) * fr[i];
        o[i] = fr[i] == 0.0 ? v : w;  /* on a frame, its value exactly (v + 0 could turn -0 to 0) */
    }
}

/* o[d] = the value between a[d] and b[d] at fraction fr (exactly a[d] at fraction 0) */
static inline void lerp_rows(const double *MRT_RESTRICT a, const double *MRT_RESTRICT b, double fr,
                             double *MRT_RESTRICT o, uint64_t D)
{
    for (uint64_t d = 0; d < D; d++) {
        double v = a[d], u = b[d];
        double w = v + (u - v) * fr;
        o[d] = fr == 0.0 ? v : w;
    }
}

#if defined(__GNUC__) && !defined(__clang__)
#define MRT_TRANSPOSE8 1
typedef double mrt_v8d __attribute__((vector_size(64)));
typedef long long mrt_v8i __attribute__((vector_size(64)));

/* Eight times (rows of frames D apart, first j0[k], second j1[k], fraction fr[k]) of features d0..d0+7, blended
 * (lerp_rows' operations) and stored feature-major, eight values to a feature: the 8 x 8 block transposed in
 * registers (shuffles: data moved, no arithmetic). */
static inline void lerp8x8(const double *rows, uint64_t D, const int32_t *j0, const int32_t *j1, const double *fr,
                           uint64_t d0, double *out, size_t ldo)
{
    mrt_v8d r[8];
    for (int k = 0; k < 8; k++) {
        mrt_v8d v, u;
        memcpy(&v, rows + (size_t)j0[k] * D + d0, sizeof v);
        memcpy(&u, rows + (size_t)j1[k] * D + d0, sizeof u);
        mrt_v8d w = v + (u - v) * fr[k];
        r[k] = fr[k] == 0.0 ? v : w;
    }
    const mrt_v8i even = {0, 8, 2, 10, 4, 12, 6, 14}, odd = {1, 9, 3, 11, 5, 13, 7, 15};
    const mrt_v8i lo2 = {0, 1, 8, 9, 4, 5, 12, 13}, hi2 = {2, 3, 10, 11, 6, 7, 14, 15};
    const mrt_v8i lo4 = {0, 1, 2, 3, 8, 9, 10, 11}, hi4 = {4, 5, 6, 7, 12, 13, 14, 15};
    mrt_v8d t[8], v[8], c[8];
    for (int k = 0; k < 8; k += 2) {
        t[k] = __builtin_shuffle(r[k], r[k + 1], even);
        t[k + 1] = __builtin_shuffle(r[k], r[k + 1], odd);
    }
    for (int k = 0; k < 8; k += 4) {
        v[k] = __builtin_shuffle(t[k], t[k + 2], lo2);
        v[k + 1] = __builtin_shuffle(t[k + 1], t[k + 3], lo2);
        v[k + 2] = __builtin_shuffle(t[k], t[k + 2], hi2);
        v[k + 3] = __builtin_shuffle(t[k + 1], t[k + 3], hi2);
    }
    for (int k = 0; k < 4; k++) {
        c[k] = __builtin_shuffle(v[k], v[k + 4], lo4);
        c[k + 4] = __builtin_shuffle(v[k], v[k + 4], hi4);
    }
    for (int k = 0; k < 8; k++)
        memcpy(out + (d0 + (uint64_t)k) * ldo, &c[k], sizeof c[k]);
}
#endif

#ifdef MRT_TRANSPOSE8
/* Every full group of eight of the m times: lerp8x8 over the features, eight at a time, the last few one by one.
 * Returns the times done (m rounded down to eight). */
static inline __attribute__((always_inline)) size_t sample8(const double *rows, uint64_t D, const int32_t *first, const int32_t *second, const double *frac,
                      size_t m, double *out, size_t ldo)
{
    size_t i0 = 0;
    for (; i0 + 8 <= m; i0 += 8) {
        uint64_t d0 = 0;
        for (; d0 + 8 <= D; d0 += 8)
            lerp8x8(rows, D, first + i0, second + i0, frac + i0, d0, out + i0, ldo);
        for (; d0 < D; d0++)
            for (size_t k = 0; k < 8; k++) {
                double v = rows[(size_t)first[i0 + k] * D + d0], u = rows[(size_t)second[i0 + k] * D + d0];
                double w = v + (u - v) * frac[i0 + k];
                out[d0 * ldo + i0 + k] = frac[i0 + k] == 0.0 ? v : w;
            }
    }
    return i0;
}
#endif

/* mrt_sample's body; `narrow`: ldo of the runtime's size (at most 128), where sample8 stores faster (wider
 * blocks, their rows 2 or 4 kB apart, store faster as below); a constant in each copy (the other path's code
 * left out of it, as it slows it down) */
static inline __attribute__((always_inline)) void sample_body(const mrt_frames *f, const double *times,
                                                              size_t count, double *out, size_t ldo, const int narrow)
{
    int32_t first[TIMES], second[TIMES];
    double frac[TIMES];
    for (size_t a = 0; a < count; a += TIMES) {
        size_t m = count - a < TIMES ? count - a : TIMES;
        positions(f->frames, times + a, m, first, second, frac);
        if (m == 1) {  /* one time (a pose alone): down the features, no set-up per feature */
            const double *r0 = f->values + first[0], *r1 = f->values + second[0];
            double fr = frac[0];
            for (uint64_t d = 0; d < f->features; d++) {
                double v = r0[d * f->frames], u = r1[d * f->frames];
                double w = v + (u - v) * fr;
                out[d * ldo + a] = fr == 0.0 ? v : w;
            }
            continue;
        }
        if (f->rows) {  /* eight times at a time: their rows blended, then stored eight values to a feature */
            uint64_t D = f->features;
            double tmp[8 * 512];
            size_t i0 = 0;
#ifdef MRT_TRANSPOSE8
            if (narrow)
                i0 = sample8(f->rows, D, first, second, frac, m, out + a, ldo);
#endif
            for (; D <= 512 && i0 < m; i0 += 8) {
                size_t n = m - i0 < 8 ? m - i0 : 8;
                for (size_t k = 0; k < n; k++)
                    lerp_rows(f->rows + (size_t)first[i0 + k] * D, f->rows + (size_t)second[i0 + k] * D,
                              frac[i0 + k], tmp + k * D, D);
                for (uint64_t d = 0; d < D; d++)
                    for (size_t k = 0; k < n; k++)
                        out[d * ldo + a + i0 + k] = tmp[k * D + d];
            }
            if (D <= 512)
                continue;
        }
        for (uint64_t d = 0; d < f->features; d++)
            lerp_gather(f->values + d * f->frames, first, second, frac, out + d * ldo + a, m);
    }
}

MRT_CLONES
static void sample_narrow(const mrt_frames *f, const double *times, size_t count, double *out, size_t ldo)
{
    sample_body(f, times, count, out, ldo, 1);
}

MRT_CLONES
static void sample_wide(const mrt_frames *f, const double *times, size_t count, double *out, size_t ldo)
{
    sample_body(f, times, count, out, ldo, 0);
}

void mrt_sample(const mrt_frames *f, const double *times, size_t count, double *out, size_t ldo)
{
    if (ldo <= 128)
        sample_narrow(f, times, count, out, ldo);
    else
        sample_wide(f, times, count, out, ldo);
}

MRT_CLONES
void mrt_sample_rows(const mrt_frames *f, const double *times, size_t count, double *out)
{
    int32_t first[TIMES], second[TIMES];
    double frac[TIMES];
    uint64_t D = f->features, F = f->frames;
    for (size_t a = 0; a < count; a += TIMES) {
        size_t m = count - a < TIMES ? count - a : TIMES;
        positions(F, times + a, m, first, second, frac);
        for (size_t i = 0; i < m; i++) {
            double *MRT_RESTRICT o = out + (a + i) * D;
            const double *r0 = f->values + first[i], *r1 = f->values + second[i];
            double fr = frac[i];
            for (uint64_t d = 0; d < D; d++) {
                double v = r0[d * F];
                double w = v + (r1[d * F] - v) * fr;
                o[d] = fr == 0.0 ? v : w;
            }
        }
    }
}

/* sa[i] = sign(x) floor(|x| / st + rounding) as a float64 (+0.0 where either is zero, as the int64 product is 0,
 * whose float64 is +0.0), d[i] = sa st, for i < N; whether each floor is below `limit`, and *same &= every new d
 * equal (==) to the old.  One loop of selects: it vectorises. */
static inline int round_run(const double *restrict x, const double *restrict st, int64_t N, double rounding,
                            double *restrict sa, double *restrict d, int *same)
{
    const double limit = 4611686018427387904.0; /* 2**62: an integer-valued a is <= 2**62 - 1 iff a < 2**62 */
    int small = 1, equal = 1;
    for (int64_t i = 0; i < N; i++) {
        const double v = x[i], a = floor(fabs(v) / st[i] + rounding);
        small &= a < limit;
        const double s = (v < 0.0 ? -a : v > 0.0 ? a : 0.0) + 0.0;
        const double e = s * st[i];
        equal &= e == d[i];
        sa[i] = s;
        d[i] = e;
    }
    *same &= equal;
    return small;
}

#define MRT_ROUND_ROWS 128 /* rows rounded together (mrt_round's work) */

/* mrt_round (mrtransform.h): the group's steps gathered once per distinct row of the table; every row, by blocks of
 * MRT_ROUND_ROWS rows laid out as one run of values (their steps copied beside them), or the subset's rows one by
 * one; the signed magnitude kept as a float64 (an integer below 2**62: exact), converted to int64 after. */
MRT_CLONES int mrt_round(const double *c, int64_t m, const double *table, int64_t K, int64_t width,
                         const int64_t *rows, const int64_t *cols, double rounding, int64_t *q, double *dq,
                         const int64_t *subset, int64_t count, int compare, double *work)
{
    double *steps = work, *S = work + K * m, *A = S + MRT_ROUND_ROWS * m;
    for (int64_t k = 0; k < K; k++)
        for (int64_t j = 0; j < m; j++)
            steps[k * m + j] = table[k * width + cols[j]];
    int same = 1;
    if (!subset) {
        for (int64_t r0 = 0; r0 < count; r0 += MRT_ROUND_ROWS) {
            const int64_t nb = count - r0 < MRT_ROUND_ROWS ? count - r0 : MRT_ROUND_ROWS, N = nb * m;
            for (int64_t r = 0; r < nb; r++)
                memcpy(S + r * m, steps + rows[r0 + r] * m, (size_t)m * sizeof(double));
            if (!round_run(c + r0 * m, S, N, rounding, A, dq + r0 * m, &same))
                return -1;
            int64_t *qr = q + r0 * m;
            for (int64_t i = 0; i < N; i++)
                qr[i] = (int64_t)A[i];
        }
    } else {
        for (int64_t s = 0; s < count; s++) {
            const int64_t r = subset[s];
            if (!round_run(c + r * m, steps + rows[r] * m, m, rounding, A, dq + r * m, &same))
                return -1;
            for (int64_t j = 0; j < m; j++)
                q[r * m + j] = (int64_t)A[j];
        }
    }
    return compare && same;
}
