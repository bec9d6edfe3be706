/* The entropy coder of `transform` payloads of versions 2 and 3 (mrcoder.h; specs/codecs.md, "Payload version 2"
 * and "Payload version 3": version 3 is version 2 with its fixed counters starting from trained states, mrprior3.h).
 *
 * A binary arithmetic coder (the carry-less range coder of LZMA: 32-bit range, bytes out with carry
 * propagation) codes every decision with a 12-bit probability. Probabilities come from adaptive counters
 * (16 bits, the rate 1 / (n + 1.5) after n updates, never below 1/64), and, for the detail coefficients, from
 * three counters under different contexts mixed in the logistic domain by an adaptive linear mixer (PAQ's
 * stretch/squash, integer tables). Integer arithmetic only: a right shift is applied to non-negative values
 * only, and a signed division is written as a floor division (asr), so the result never depends on what C
 * leaves to the implementation.
 */
#include "mrcoder.h"
#include "mrprior3.h"

#include <stdlib.h>
#include <string.h>

/* The coder's functions are written once for both directions (a `dec` argument) and inlined into the encoder's
 * and the decoder's loop, each compiled with `dec` a constant: no test of the direction per decision. */
#if defined(__GNUC__)
#define MRC_INLINE static inline __attribute__((always_inline))
#else
#define MRC_INLINE static inline
#endif

/* ------------------------------------------------------------------------------------------------------- */
/* integer helpers                                                                                           */
/* ------------------------------------------------------------------------------------------------------- */

/* floor(x / 2 ** s) for any sign of x (int64_t is two's complement: ~x = -x - 1 >= 0 for x < 0, and
 * floor(x / 2 ** s) = ~floor(~x / 2 ** s); both arms a right shift of a non-negative value, one instruction) */
MRC_INLINE int64_t asr(int64_t x, int s) {
    return x >= 0 ? (x >> s) : ~(~x >> s);
}

MRC_INLINE int bitlen(uint64_t x) {
#if defined(__GNUC__)
    return x ? 64 - __builtin_clzll(x) : 0;
#else
    int n = 0;
    while (x) {
        n++;
        x >>= 1;
    }
    return n;
#endif
}

/* class of a non-negative context sum: 0 for 0, then two classes per octave, capped */
MRC_INLINE int qclass(int64_t s, int nclass) {
    if (s <= 0) return 0;
    int n = bitlen((uint64_t)s);
    int c = 2 * n - 1 + (n >= 2 ? (int)((s >> (n - 2)) & 1) : 0);
    return c < nclass - 1 ? c : nclass - 1;
}

MRC_INLINE int64_t cap(int64_t v) {
    int64_t m = v < 0 ? -v : v;
    return m < (1 << 24) ? m : (1 << 24);
}

MRC_INLINE int sign3(int64_t v) { return v == 0 ? 0 : (v > 0 ? 1 : 2); }

/* ------------------------------------------------------------------------------------------------------- */
/* probability models                                                                                        */
/* ------------------------------------------------------------------------------------------------------- */

typedef struct {
    uint16_t p; /* P(1) in 1/65536 */
    uint16_t n; /* updates seen, capped at 63 */
} Counter;

#define P_LOW 16
#define P_HIGH (65536 - 16)

static void counters_init(Counter *c, size_t n) {
    for (size_t i = 0; i < n; i++) {
        c[i].p = 32768;
        c[i].n = 0;
    }
}

/* the rate after n updates: max(1024, floor(131072 / (2 n + 3))), i.e. 1 / (n + 1.5) in 1/65536, not below 1/64;
 * a table of the 63 values above the floor (a division per decision would cost as much as the rest) */
static const uint16_t RATES[64] = {
    43690, 26214, 18724, 14563, 11915, 10082, 8738, 7710, 6898, 6241, 5698, 5242,
    4854, 4519, 4228, 3971, 3744, 3542, 3360, 3196, 3048, 2912, 2788, 2674,
    2570, 2473, 2383, 2299, 2221, 2148, 2080, 2016, 1956, 1899, 1846, 1795,
    1747, 1702, 1659, 1618, 1579, 1542, 1506, 1472, 1440, 1409, 1379, 1351,
    1323, 1297, 1272, 1248, 1224, 1202, 1180, 1159, 1139, 1120, 1101, 1083,
    1065, 1048, 1032, 1024,
};

/* (n stops at 63, where the rate stops changing: the same rates as counting on) */
MRC_INLINE void counter_update(Counter *c, int y) {
    uint32_t r = RATES[c->n];
    uint32_t p = c->p;
    if (y)
        p += (uint32_t)(((uint64_t)(65536u - p) * r) >> 16);
    else
        p -= (uint32_t)(((uint64_t)p * r) >> 16);
    if (p < P_LOW) p = P_LOW;
    if (p > P_HIGH) p = P_HIGH;
    c->p = (uint16_t)p;
    c->n += c->n < 63;
}

MRC_INLINE int counter_p12(const Counter *c) { return c->p >> 4; } /* 1..4094 */

/* PAQ's squash (logistic function on stretch units of 1/256 natural-log odds) by interpolation of 33 points,
 * and stretch, its inverse, as a table */
static const int SQUASH_T[33] = {1,    2,    3,    6,    10,   16,   27,   45,   73,   120,  194,
                                 310,  488,  747,  1101, 1546, 2047, 2549, 2994, 3348, 3607, 3785,
                                 3901, 3975, 4022, 4050, 4068, 4079, 4085, 4089, 4092, 4093, 4094};

static int squash(int d) {
    if (d > 2047) return 4095;
    if (d < -2047) return 1;
    int u = d + 2048; /* 1..4095 */
    int i = u >> 7, w = u & 127;
    return (SQUASH_T[i] * (128 - w) + SQUASH_T[i + 1] * w + 64) >> 7;
}

#define N0 20 /* classes of the whole neighbourhood sum (detail contexts, below) */
#define N1 12 /* classes of the time and of the parent neighbourhood */

#define MIX_INPUTS 3
#define MIX_SETS 18
#define MIX_INIT 19661 /* 0.3 in 1/65536 */
#define MIX_RATE 82    /* learning rate 0.02: w += err12 * st * 82 / 65536 */
#define MIX_LIMIT (1 << 24) /* |w| <= 256 (real clips stay within a few units): no overflow on any data */

/* qclass(s, N0) is N0 - 1 from s = 512 on, qclass(s, N1) N1 - 1 from 32 on: tables up to there */
#define CLS0_TOP 512
#define CLS1_TOP 32

typedef struct {
    int16_t stretch[4096];
    int16_t squash[4095]; /* squash(d - 2047), d = 0..4094: one load per decision instead of the interpolation */
    uint8_t cls0[CLS0_TOP + 1], cls1[CLS1_TOP + 1]; /* qclass(s, N0), qclass(s, N1) up to the top (decode_details) */
    int32_t fall[4095]; /* -MIX_RATE squash(d - 2047): the weights' step after a 0 is floor(st fall / 65536) */
} Tables;

static void tables_init(Tables *t) {
    for (int d = -2047; d <= 2047; d++) t->squash[d + 2047] = (int16_t)squash(d);
    int pi = 0;
    for (int x = -2047; x <= 2047; x++) {
        int v = t->squash[x + 2047];
        for (int i = pi; i <= v; i++) t->stretch[i] = (int16_t)x;
        pi = v + 1;
    }
    for (int i = pi; i < 4096; i++) t->stretch[i] = 2047;
    for (int d = 0; d < 4095; d++) t->fall[d] = -MIX_RATE * t->squash[d];
    for (int i = 0; i <= CLS0_TOP; i++) t->cls0[i] = (uint8_t)qclass(i, N0);
    for (int i = 0; i <= CLS1_TOP; i++) t->cls1[i] = (uint8_t)qclass(i, N1);
}


typedef struct {
    int32_t w[MIX_SETS][MIX_INPUTS];
} Mixer;

static void mixer_init(Mixer *m) {
    for (int s = 0; s < MIX_SETS; s++)
        for (int i = 0; i < MIX_INPUTS; i++) m->w[s][i] = MIX_INIT;
}

/* ------------------------------------------------------------------------------------------------------- */
/* the range coder                                                                                           */
/* ------------------------------------------------------------------------------------------------------- */

typedef struct {
    uint8_t *buf;
    size_t len, cap;
    uint64_t low;
    uint32_t range;
    uint8_t cache;
    uint64_t pending;
    int first, err;
} Enc;

static void enc_put(Enc *e, uint8_t b) {
    if (e->first) { /* the first byte is always 0: not stored */
        e->first = 0;
        return;
    }
    if (e->len == e->cap) {
        size_t cap = e->cap ? 2 * e->cap : 1024;
        uint8_t *nb = (uint8_t *)realloc(e->buf, cap);
        if (!nb) {
            e->err = MRC_E_MEMORY;
            return;
        }
        e->buf = nb;
        e->cap = cap;
    }
    e->buf[e->len++] = b;
}

static void enc_shift(Enc *e) {
    if ((uint32_t)e->low < 0xFF000000u || (e->low >> 32) != 0) {
        uint8_t carry = (uint8_t)(e->low >> 32);
        uint8_t temp = e->cache;
        do {
            enc_put(e, (uint8_t)(temp + carry));
            temp = 0xFF;
        } while (--e->pending != 0);
        e->cache = (uint8_t)(e->low >> 24);
    }
    e->pending++;
    e->low = (e->low & 0x00FFFFFFu) << 8;
}

static void enc_init(Enc *e) {
    memset(e, 0, sizeof *e);
    e->range = 0xFFFFFFFFu;
    e->pending = 1;
    e->first = 1;
}

/* code y (0/1) with P(1) = p12 / 4096, 1 <= p12 <= 4095 */
static void enc_bit(Enc *e, int p12, int y) {
    uint32_t bound = (e->range >> 12) * (uint32_t)p12;
    if (y)
        e->range = bound;
    else {
        e->low += bound;
        e->range -= bound;
    }
    while (e->range < (1u << 24)) {
        e->range <<= 8;
        enc_shift(e);
    }
}

/* the shortest ending: the value in [low, low + range) with the most trailing zero bits, whose zero bytes at
 * the end are then dropped (the decoder reads zeros past the end; only the ending's own bytes are dropped, so
 * that the decoder can tell a truncated stream: it reads at most 5 bytes past the end of a whole one) */
static void enc_finish(Enc *e) {
    size_t before = e->len;
    uint64_t hi = e->low + e->range - 1;
    for (int k = 32; k >= 0; k--) {
        uint64_t mask = ((uint64_t)1 << k) - 1;
        uint64_t v = (e->low + mask) & ~mask;
        if (v <= hi) {
            e->low = v;
            break;
        }
    }
    for (int i = 0; i < 5; i++) enc_shift(e);
    while (e->len > before && e->buf[e->len - 1] == 0) e->len--;
}

typedef struct {
    const uint8_t *data;
    size_t len, pos;
    uint32_t range, code;
} Dec;

MRC_INLINE uint8_t dec_next(Dec *d) {
    uint8_t b = d->pos < d->len ? d->data[d->pos] : 0;
    d->pos++;
    return b;
}

static void dec_init(Dec *d, const uint8_t *data, size_t len) {
    d->data = data;
    d->len = len;
    d->pos = 0;
    d->range = 0xFFFFFFFFu;
    d->code = 0;
    for (int i = 0; i < 4; i++) d->code = (d->code << 8) | dec_next(d);
}

MRC_INLINE int dec_bit(Dec *d, int p12) {
    uint32_t bound = (d->range >> 12) * (uint32_t)p12;
    int y;
    if (d->code < bound) {
        d->range = bound;
        y = 1;
    } else {
        d->code -= bound;
        d->range -= bound;
        y = 0;
    }
    while (d->range < (1u << 24)) {
        d->range <<= 8;
        d->code = (d->code << 8) | dec_next(d);
    }
    return y;
}

/* ------------------------------------------------------------------------------------------------------- */
/* one coder for both directions: `dec` 0 encodes `*y`, else decodes into it (a constant where inlined)       */
/* ------------------------------------------------------------------------------------------------------- */

typedef struct {
    int16_t *stretch; /* FIXED_COUNT each */
    uint16_t *count;
} MrcStates;

typedef struct {
    Enc *enc;
    Dec d;           /* the decoder's state, by value: code_body works on a local copy the compiler keeps in registers */
    const Tables *t;
    Mixer *mix;
} Coder;

#if defined(__GNUC__)
#define MRC_LIKELY(x) __builtin_expect(!!(x), 1)
#define MRC_UNLIKELY(x) __builtin_expect(!!(x), 0)
#define MRC_NOINLINE __attribute__((noinline))
#else
#define MRC_LIKELY(x) (x)
#define MRC_UNLIKELY(x) (x)
#define MRC_NOINLINE
#endif

/* floor(x / 2 ** s) of an int32_t (asr's) */
MRC_INLINE int32_t asr32(int32_t x, int s) {
    return x >= 0 ? (x >> s) : ~(~x >> s);
}

/* code_mixed's weight update w + floor(st err MIX_RATE / 65536), clamped, with f = err MIX_RATE: |st err MIX_RATE|
 * <= 2047 x 4095 x 82 < 2 ** 31 and |w| <= 2 ** 24, so int32 throughout, the same integers */
MRC_INLINE int32_t mix_step(int32_t w, int st, int32_t f) {
    int32_t v = w + asr32(st * f, 16);
    if (MRC_UNLIKELY((uint32_t)(v + MIX_LIMIT) > 2u * MIX_LIMIT)) v = v > 0 ? MIX_LIMIT : -MIX_LIMIT;
    return v;
}

MRC_INLINE int code_bit(const int dec, Coder *c, int p12, int y) {
    if (dec) return dec_bit(&c->d, p12);
    enc_bit(c->enc, p12, y);
    return y;
}

MRC_INLINE int code_counter(const int dec, Coder *c, Counter *k, int y) {
    y = code_bit(dec, c, counter_p12(k), y);
    counter_update(k, y);
    return y;
}

MRC_INLINE int code_raw(const int dec, Coder *c, int y) { return code_bit(dec, c, 2048, y); }

/* a decision from the counters k[0..n-1], mixed with the weights w (a set of c->mix.w, or a copy of one the
 * caller keeps in registers) */
MRC_INLINE int code_mixed(const int dec, Coder *c, Counter **k, int n, int32_t *w, int y) {
    int st[MIX_INPUTS];
    int64_t dot = 0;
    for (int i = 0; i < n; i++) {
        st[i] = c->t->stretch[counter_p12(k[i])];
        dot += (int64_t)w[i] * st[i];
    }
    int64_t x = asr(dot, 16);
    int p = c->t->squash[(x > 2047 ? 2047 : (x < -2047 ? -2047 : (int)x)) + 2047]; /* 1..4095 */
    y = code_bit(dec, c, p, y);
    int f = ((y << 12) - p) * MIX_RATE; /* the error times the rate */
    for (int i = 0; i < n; i++) {
        w[i] = mix_step(w[i], st[i], f);
        counter_update(k[i], y);
    }
    return y;
}

/* generic signed integers (exponents, approximation): zero, sign, bit length in unary, two mantissa bits
 * under counters, the rest raw */
#define G_ZERO 0
#define G_SIGN 1
#define G_LEN 2
#define G_MANT (G_LEN + 64)
#define G_SIZE (G_MANT + 2 * 64)
#define G_MAXBITS 63

MRC_INLINE int code_sint(const int dec, Coder *c, Counter *set, int64_t *v) {
    int64_t x = dec ? 0 : *v;
    uint64_t m = x < 0 ? (uint64_t)(-(x + 1)) + 1 : (uint64_t)x;
    int nz = code_counter(dec, c, &set[G_ZERO], m != 0);
    if (!nz) {
        *v = 0;
        return MRC_OK;
    }
    int neg = code_counter(dec, c, &set[G_SIGN], x < 0);
    int n = dec ? 0 : bitlen(m);
    int k = 1;
    for (; k < G_MAXBITS; k++)
        if (!code_counter(dec, c, &set[G_LEN + k], k < n)) break;
    n = k;
    uint64_t r = 1;
    for (int b = n - 2; b >= 0; b--) {
        int bit = dec ? 0 : (int)((m >> b) & 1);
        if (b >= n - 3)
            bit = code_counter(dec, c, &set[G_MANT + 2 * n + (n - 2 - b)], bit);
        else
            bit = code_raw(dec, c, bit);
        r = (r << 1) | (uint64_t)bit;
    }
    if (dec) { /* r < 2 ** 63 */
        *v = neg ? -(int64_t)r : (int64_t)r;
    }
    return MRC_OK;
}

/* ------------------------------------------------------------------------------------------------------- */
/* the payload                                                                                               */
/* ------------------------------------------------------------------------------------------------------- */

int mrc_level_sizes(int64_t frames, int64_t *sizes) {
    int64_t details[20];
    int levels = 0;
    int64_t n = frames;
    while (n >= 4 && levels < 20) {
        details[levels++] = n / 2;
        n = (n + 1) / 2;
    }
    sizes[0] = n;
    for (int i = 0; i < levels; i++) sizes[1 + i] = details[levels - 1 - i];
    return levels;
}

const char *mrc_error_text(int code) {
    switch (code) {
    case MRC_OK: return "no error";
    case MRC_E_HEADER: return "the head (frames, features, region) is malformed or out of range";
    case MRC_E_TOO_MANY: return "more values than the bytes can hold (damaged data)";
    case MRC_E_EXPONENT: return "a step exponent is out of range (damaged data)";
    case MRC_E_MAGNITUDE: return "a coefficient is out of range (damaged data)";
    case MRC_E_TRUNCATED: return "the coded data ends early (damaged data)";
    case MRC_E_TRAILING: return "bytes after the coded data (damaged data)";
    case MRC_E_MEMORY: return "out of memory";
    case MRC_E_ARGUMENT: return "a value the encoder cannot code";
    default: return "unknown error";
    }
}

/* LEB128, canonical, at most 5 bytes, value <= limit */
static int read_varint(const uint8_t *data, size_t len, size_t *pos, uint64_t limit, uint64_t *out) {
    uint64_t v = 0;
    for (int i = 0; i < 5; i++) {
        if (*pos >= len) return MRC_E_HEADER;
        uint8_t b = data[(*pos)++];
        v |= (uint64_t)(b & 0x7F) << (7 * i);
        if (!(b & 0x80)) {
            if (i > 0 && b == 0) return MRC_E_HEADER; /* not the shortest form */
            if (v > limit) return MRC_E_HEADER;
            *out = v;
            return MRC_OK;
        }
    }
    return MRC_E_HEADER;
}

static size_t write_varint(uint8_t *out, uint64_t v) {
    size_t n = 0;
    do {
        uint8_t b = v & 0x7F;
        v >>= 7;
        out[n++] = (uint8_t)(b | (v ? 0x80 : 0));
    } while (v);
    return n;
}

static int64_t count_regions(int64_t frames, int64_t region) { return (frames + region - 1) / region; }

static int head(const uint8_t *data, size_t len, int64_t *frames, int64_t *features, int64_t *region,
                size_t *body) {
    uint64_t f, d, r;
    size_t pos = 0;
    int e;
    if ((e = read_varint(data, len, &pos, (uint64_t)MRC_MAX_FRAMES - 1, &f))) return e;
    if ((e = read_varint(data, len, &pos, (uint64_t)MRC_MAX_FEATURES - 1, &d))) return e;
    if ((e = read_varint(data, len, &pos, (uint64_t)MRC_MAX_REGION - 1, &r))) return e;
    *frames = (int64_t)f + 1;
    *features = (int64_t)d + 1;
    *region = (int64_t)r + 1;
    *body = pos;
    return MRC_OK;
}

/* F * D + D + R within MRC_VALUES_PER_BYTE per byte (F < 2 ** 32, D <= 2 ** 20: no overflow) */
static int values_fit(int64_t frames, int64_t features, int64_t region, size_t len) {
    int64_t values = frames * features + features + count_regions(frames, region);
    return (uint64_t)values <= (uint64_t)MRC_VALUES_PER_BYTE * (uint64_t)len;
}

int mrc_declared(const uint8_t *data, size_t len, int64_t *frames, int64_t *features, int64_t *region) {
    size_t body;
    return head(data, len, frames, features, region, &body);
}

int mrc_fits(int64_t frames, int64_t features, int64_t region, size_t len) {
    return values_fit(frames, features, region, len);
}

/* detail contexts */
#define BANDS 2
#define C0 (BANDS * N0)
#define C1 (BANDS * N1 * N1)
#define FEAT 1024 /* per-feature contexts (feature index modulo this) */
#define LEVELS 13
#define MAGS 16
#define SIGNS 9

typedef struct {
    Counter gen[5][G_SIZE]; /* active flags (first 2 entries of set 0), exponents, regions, approximation */
    Counter z0[C0], z1[C1], *z2;
    Counter s0[SIGNS], *s2;
    Counter m0[C0 * MAGS], m1[C1 * MAGS], *m2;
    Counter mant[64 * 2];
    int64_t feat; /* per-feature contexts per level that can occur: min(D, FEAT) (z2, s2, m2 hold LEVELS x feat) */
} Models;

/* (The per-feature contexts (level, feature modulo FEAT) are stored for the features a clip has only: the same
 * contexts, fewer counters to set up.) */
/* The fixed counters of Models in one order (the order of mrprior3.h's table): gen, z0, z1, s0, m0, m1, mant. */
#define FIXED_COUNT (5 * G_SIZE + C0 + C1 + SIGNS + C0 * MAGS + C1 * MAGS + 64 * 2)

typedef struct {
    Counter *at;
    int count;
} Span;

static void fixed_spans(Models *m, Span s[7]) {
    s[0].at = &m->gen[0][0];
    s[0].count = 5 * G_SIZE;
    s[1].at = m->z0;
    s[1].count = C0;
    s[2].at = m->z1;
    s[2].count = C1;
    s[3].at = m->s0;
    s[3].count = SIGNS;
    s[4].at = m->m0;
    s[4].count = C0 * MAGS;
    s[5].at = m->m1;
    s[5].count = C1 * MAGS;
    s[6].at = m->mant;
    s[6].count = 64 * 2;
}

/* the fixed counters' start: version 2's (P(1) = 1/2, no update seen) or version 3's (mrprior3.h: for each
 * counter its P(1) in 1/65536 and its count of updates seen, 0 where it keeps version 2's start) */
static void fixed_init(Models *m, int version) {
    Span s[7];
    fixed_spans(m, s);
    int idx = 0;
    for (int a = 0; a < 7; a++) {
        if (version < 3) {
            counters_init(s[a].at, (size_t)s[a].count);
            continue;
        }
        for (int i = 0; i < s[a].count; i++, idx++) {
            s[a].at[i].p = MRC_PRIOR3[idx][0];
            s[a].at[i].n = MRC_PRIOR3[idx][1];
        }
    }
}

static int models_init(Models *m, int64_t D, int version) {
    fixed_init(m, version);
    m->feat = D < FEAT ? D : FEAT;
    size_t c2 = (size_t)(LEVELS * m->feat), n2 = c2 * (1 + 1 + MAGS);
    Counter *all = (Counter *)malloc(n2 * sizeof(Counter));
    if (!all) return MRC_E_MEMORY;
    counters_init(all, n2);
    m->z2 = all;
    m->s2 = all + c2;
    m->m2 = all + 2 * c2;
    return MRC_OK;
}

static void models_free(Models *m) { free(m->z2); }

typedef char fixed_count_matches_table[(FIXED_COUNT == MRC_PRIOR3_SIZE && FIXED_COUNT == MRC_STATES) ? 1 : -1];

enum { GEN_ACTIVE = 0, GEN_FEXP = 1, GEN_REXP = 2, GEN_FIRST = 3, GEN_DIFF = 4 };

#define LIMIT ((((int64_t)1) << MRC_MAX_BITS) - 1)

/* The rows a detail row's contexts read: the two rows before it in its band (up1, up2, where they exist) and its
 * parents (pk, pk2; for the band next to the approximation, the two approximation rows whose difference is the
 * parent, where there are two); the coefficient of column `col` of a row at row[col * cs]. */
typedef struct {
    const int64_t *up1, *up2, *pk, *pk2;
    int has1, has2, approx, j;
    int64_t cs;
} Rows;

/* the rows of detail row i of a band of level j whose parents are the np rows `par` (`approx`: the approximation);
 * rows rs apart, columns cs apart */
MRC_INLINE Rows rows_of(int64_t *cur, int64_t i, const int64_t *par, int64_t np, int approx, int j, int64_t rs,
                        int64_t cs) {
    Rows r;
    r.has1 = i >= 1;
    r.has2 = i >= 2;
    r.up1 = cur + (i >= 1 ? i - 1 : 0) * rs;
    r.up2 = cur + (i >= 2 ? i - 2 : 0) * rs;
    r.approx = approx;
    r.j = j;
    r.cs = cs;
    if (approx) {
        int64_t k = i < np - 1 ? i : np - 1;
        int64_t k2 = k + 1 < np - 1 ? k + 1 : np - 1;
        r.pk = par + k * rs;
        r.pk2 = par + k2 * rs; /* with one row (np 1), pk2 = pk: the difference is 0 */
    } else {
        int64_t k = i / 2 < np - 1 ? i / 2 : np - 1;
        int64_t k2 = (i & 1) ? (k + 1 < np - 1 ? k + 1 : np - 1) : (k >= 1 ? k - 1 : 0);
        r.pk = par + k * rs;
        r.pk2 = par + k2 * rs;
    }
    return r;
}

/* the sign and the magnitude of a detail coefficient x whose zero flag was 1, under contexts a0, a1, a2 and the
 * sign context sc (code_detail's); returns x (decoded when `dec`) */
MRC_INLINE int64_t code_nonzero(const int dec, Coder *c, Models *m, int a0, int a1, int a2, int sc, int64_t x) {
    uint64_t mag = x < 0 ? (uint64_t)(-x) : (uint64_t)x;
    Counter *k[MIX_INPUTS];
    k[0] = &m->s0[sc];
    k[1] = &m->s2[a2];
    int neg = code_mixed(dec, c, k, 2, c->mix->w[1], x < 0);
    int n = dec ? 0 : bitlen(mag);
    int b = 1;
    for (; b < MRC_MAX_BITS; b++) {
        int q = b < MAGS - 1 ? b : MAGS - 1;
        k[0] = &m->m0[a0 * MAGS + q];
        k[1] = &m->m1[a1 * MAGS + q];
        k[2] = &m->m2[(size_t)a2 * MAGS + q];
        if (!code_mixed(dec, c, k, 3, c->mix->w[2 + q], b < n)) break;
    }
    n = b;
    uint64_t r = 1;
    for (int s = n - 2; s >= 0; s--) {
        int bit = dec ? 0 : (int)((mag >> s) & 1);
        if (s >= n - 3)
            bit = code_counter(dec, c, &m->mant[2 * n + (n - 2 - s)], bit);
        else
            bit = code_raw(dec, c, bit);
        r = (r << 1) | (uint64_t)bit;
    }
    return neg ? -(int64_t)r : (int64_t)r; /* r < 2 ** 62 */
}

/* one detail coefficient, row[col * rw->cs], with the rows `rw` around it and r1 = cap(row[col - 1]) (0 for col 0): the
 * contexts of specs/codecs.md, "Payload version 2"; returns cap(row[col]), the next coefficient's r1 (from the
 * value decoded, not from memory: a zero is known as soon as its decision is) */
MRC_INLINE int64_t code_detail(const int dec, Coder *c, Models *m, int64_t *row, const Rows *rw, int64_t col, int64_t r1,
                           int32_t *wzero) {
    const int64_t at = col * rw->cs;
    int64_t u1 = rw->has1 ? rw->up1[at] : 0;
    int64_t t1 = cap(u1);
    int64_t t2 = rw->has2 ? cap(rw->up2[at]) : 0;
    int64_t pa, pn, ps;
    if (rw->approx) {
        pa = cap(rw->pk2[at] - rw->pk[at]);
        pn = pa;
        ps = 0;
    } else {
        ps = rw->pk[at];
        pa = cap(ps);
        pn = cap(rw->pk2[at]);
    }
    int j = rw->j;
    int bc = j <= 1 ? 0 : 1;
    int a0 = bc * N0 + qclass(3 * t1 + t2 + 2 * pa + pn + r1, N0);
    int a1 = (bc * N1 + qclass(2 * t1 + t2, N1)) * N1 + qclass(2 * pa + pn, N1);
    int a2 = (j < LEVELS - 1 ? j : LEVELS - 1) * (int)m->feat + (int)((uint64_t)col % FEAT);
    int64_t x = dec ? 0 : row[at];
    uint64_t mag = x < 0 ? (uint64_t)(-x) : (uint64_t)x;
    Counter *k[MIX_INPUTS];
    k[0] = &m->z0[a0];
    k[1] = &m->z1[a1];
    k[2] = &m->z2[a2];
    if (!code_mixed(dec, c, k, 3, wzero, mag != 0)) {
        row[at] = 0;
        return 0;
    }
    x = code_nonzero(dec, c, m, a0, a1, a2, 3 * sign3(u1) + sign3(ps), x);
    if (dec) row[at] = x;
    return cap(x);
}

/* ------------------------------------------------------------------------------------------------------- */
/* the decoder's own loop over the details                                                                   */
/* ------------------------------------------------------------------------------------------------------- */

/* mrc_decode_version decodes the details with decode_details: the decisions of code_body's loop (which
 * mrc_decode_reference still runs, dec = 1), in the same order with the same integer arithmetic, so the same
 * integers from any bytes, damaged or not (tests/test_stream2.py compares the two). What differs is the work
 * around the decisions: per row, the parts of each active column's contexts that do not depend on the row being
 * decoded (its rows above and its parents) are computed first, in a loop without decisions; then the zero flags,
 * nearly every decision of a clip, are decoded with the zero outcome straight-line (weights in registers, the
 * counters of y = 0), and a non-zero coefficient's sign and magnitude go through code_nonzero as before. */

typedef struct {
    Counter *k0, *k1, *k2; /* the zero flag's counters (k0 where r1 is 0: decode_details replaces it after a non-zero) */
    int32_t nb;            /* 3 t1 + t2 + 2 pa + pn (capped magnitudes: below 2 ** 27): a0's sum without r1 */
    int32_t a1;
} ColCtx;

/* qclass(s, N0) and qclass(s, N1) of s >= 0, by table */
MRC_INLINE int cls0(const Tables *t, int64_t s) { return t->cls0[s < CLS0_TOP ? s : CLS0_TOP]; }
MRC_INLINE int cls1(const Tables *t, int64_t s) { return t->cls1[s < CLS1_TOP ? s : CLS1_TOP]; }

/* The zero flag's contexts of every active column of the detail row `rw` (the columns act[0..na-1]), and the
 * row's coefficients set to 0 (decode_details writes the non-zero ones) */
static void row_contexts(const Tables *t, Models *m, const Rows *rw, int64_t *row, const int32_t *act, int64_t na,
                         int bc, Counter *z2, ColCtx *cc) {
    const int64_t cs = rw->cs;
    const int64_t *up1 = rw->has1 ? rw->up1 : row, *up2 = rw->has2 ? rw->up2 : row; /* row: zeros (below) */
    Counter *k0 = &m->z0[bc * N0], *k1 = &m->z1[bc * N1 * N1]; /* the contexts of an all-zero neighbourhood */
    for (int64_t k = 0; k < na; k++) {
        const int64_t at = act[k] * cs;
        row[at] = 0;
        int64_t u1 = up1[at], u2 = up2[at], q1 = rw->pk[at], q2 = rw->pk2[at];
        cc[k].k2 = &z2[(uint64_t)act[k] % FEAT];
        if (MRC_LIKELY(!(u1 | u2 | q2 | (rw->approx ? 0 : q1)))) { /* (approx: q2 - q1, 0 when q2 is) */
            if (!rw->approx || !q1) {
                cc[k].k0 = k0;
                cc[k].k1 = k1;
                cc[k].nb = 0;
                cc[k].a1 = bc * N1 * N1;
                continue;
            }
        }
        int64_t t1 = cap(u1), t2 = cap(u2), pa, pn;
        if (rw->approx) {
            pa = cap(q2 - q1);
            pn = pa;
        } else {
            pa = cap(q1);
            pn = cap(q2);
        }
        int64_t nb = 3 * t1 + t2 + 2 * pa + pn;
        int a1 = (bc * N1 + cls1(t, 2 * t1 + t2)) * N1 + cls1(t, 2 * pa + pn);
        cc[k].k0 = &m->z0[bc * N0 + cls0(t, nb)];
        cc[k].k1 = &m->z1[a1];
        cc[k].nb = (int32_t)nb;
        cc[k].a1 = a1;
    }
}

/* counter_update(k, 0): a counter past 62 updates has the rate 1024, p - (p * 1024 >> 16) = p - (p >> 6), which
 * stays within [P_LOW, P_HIGH] from there (p >= 16: p >> 6 < p - 15), its count at 63 */
MRC_INLINE void counter_update0(Counter *k) {
    if (MRC_LIKELY(k->n == 63)) k->p = (uint16_t)(k->p - (k->p >> 6));
    else counter_update(k, 0);
}

static MRC_NOINLINE uint32_t dec_refill(Dec *d, uint32_t *range, uint32_t code) {
    while (*range < (1u << 24)) {
        *range <<= 8;
        code = (code << 8) | dec_next(d);
    }
    return code;
}

/* A non-zero detail coefficient (its zero flag decided 1 with probability p from the counters of x and the
 * stretches s[3] under the weights w): the rest of the flag's decision (range, weights, counters), its sign and its
 * magnitude (code_nonzero) into *out, and the next column's k0 (x[1], when `next` says it is the next feature).
 * Out of the hot loop, the decoder's state passed through c. */
static MRC_NOINLINE void decode_nonzero(Coder *c, Models *m, const Rows *rw, ColCtx *x, int64_t at, int64_t *out,
                                        int next, int bc, int32_t *w, const int *s, int p, uint32_t bound) {
    c->d.range = bound;
    if (bound < (1u << 24)) c->d.code = dec_refill(&c->d, &c->d.range, c->d.code);
    for (int i = 0; i < 3; i++) w[i] = mix_step(w[i], s[i], (4096 - p) * MIX_RATE);
    counter_update(x->k0, 1);
    counter_update(x->k1, 1);
    counter_update(x->k2, 1);
    int64_t u1 = rw->has1 ? rw->up1[at] : 0, ps = rw->approx ? 0 : rw->pk[at];
    int64_t v = code_nonzero(1, c, m, (int)(x->k0 - m->z0), x->a1, (int)(x->k2 - m->z2), 3 * sign3(u1) + sign3(ps), 0);
    *out = v;
    if (next) x[1].k0 = &m->z0[bc * N0 + cls0(c->t, x[1].nb + cap(v))];
}

/* The state quiet_run reads and leaves: the range decoder's, the zero flags' weights, and where it stopped. */
typedef struct {
    uint32_t range, code;
    int32_t w[3];
    int s[3], p;     /* at a non-zero flag: the stretches and the probability of its decision */
    uint32_t bound;  /* and its bound (the decision itself is left to the caller) */
} Run;

/* the largest step of a zero flag's weight, |asr(st fall[e], 16)| <= floor(2047 x 82 x 4095 / 65536) + 1 */
#define ZERO_STEP_MAX 10489

/* A zero flag's decision from the stretches s0..s2 of its counters under the weights *w0..*w2 (quiet_loop's and
 * busy_loop's): 0 when it is zero, the range decoder and the weights advanced (the counters are the caller's to
 * update; `free`: no clamp, see quiet_loop); 1 when it is not, nothing changed but run's s, p and bound, with which
 * decode_nonzero finishes the decision. */
MRC_INLINE int zero_flag(const int free, const Tables *t, int64_t s0, int64_t s1, int64_t s2, int64_t *w0,
                         int64_t *w1, int64_t *w2, uint32_t *range, uint32_t *code, Run *run) {
    int64_t e = asr(*w0 * s0 + *w1 * s1 + *w2 * s2, 16);
    if (MRC_UNLIKELY((uint64_t)(e + 2047) > 4094)) e = e > 0 ? 2047 : -2047;
    int p = t->squash[e + 2047]; /* 1..4095 */
    uint32_t bound = (*range >> 12) * (uint32_t)p;
    if (MRC_UNLIKELY(*code < bound)) {
        run->s[0] = (int)s0;
        run->s[1] = (int)s1;
        run->s[2] = (int)s2;
        run->p = p;
        run->bound = bound;
        return 1;
    }
    *code -= bound;
    *range -= bound;
    int64_t f = t->fall[e + 2047]; /* -p MIX_RATE */
    if (free) { /* mix_step without its clamp (|w| stays below MIX_LIMIT) */
        *w0 += asr(s0 * f, 16);
        *w1 += asr(s1 * f, 16);
        *w2 += asr(s2 * f, 16);
    } else {
        *w0 = mix_step((int32_t)*w0, (int)s0, (int32_t)f);
        *w1 = mix_step((int32_t)*w1, (int)s1, (int32_t)f);
        *w2 = mix_step((int32_t)*w2, (int)s2, (int32_t)f);
    }
    return 0;
}

/* whether no zero flag's weight of `run` can reach MIX_LIMIT within n decisions */
static int run_free(const Run *run, int64_t n) {
    int64_t room = MIX_LIMIT - ZERO_STEP_MAX * n; /* what a weight may be and not reach the clamp */
    int free = 1;
    for (int i = 0; i < 3; i++) free &= -room <= run->w[i] && run->w[i] <= room;
    return free;
}

/* a run's mixing weights and coder state back into run, where the loops kept them in registers */
MRC_INLINE void run_store(Run *run, int64_t w0, int64_t w1, int64_t w2, uint32_t range, uint32_t code) {
    run->w[0] = (int32_t)w0;
    run->w[1] = (int32_t)w1;
    run->w[2] = (int32_t)w2;
    run->range = range;
    run->code = code;
}

/* what a run ended with back into the caller's state: the mixing weights, the coder's range and code, and the
 * pending flag's stretches, probability and bound */
MRC_INLINE void run_load(const Run *run, int32_t *w, uint32_t *range, uint32_t *code, int *s, int *p,
                         uint32_t *bound) {
    memcpy(w, run->w, sizeof run->w);
    *range = run->range;
    *code = run->code;
    memcpy(s, run->s, sizeof run->s);
    *p = run->p;
    *bound = run->bound;
}

/* quiet_run's loop; `sat`: both shared counters past 62 updates (then they stay there: no count to keep); `free`:
 * no weight can reach MIX_LIMIT within the run (then mix_step's clamp is left out).  The loop is bound by the
 * number of its operations as much as by the chain from one decision to the next, so it has as few as the
 * decisions allow: 64-bit weights and stretches (no widening), no clamp where none can happen. */
MRC_INLINE int64_t quiet_loop(const int sat, const int free, Coder *c, Counter *K0, Counter *K1, Counter *z2,
                              int64_t *row, const int32_t *act, int64_t k, int64_t na, int64_t cs, Run *run) {
    const Tables *t = c->t;
    int64_t w0 = run->w[0], w1 = run->w[1], w2 = run->w[2];
    uint32_t range = run->range, code = run->code;
    Counter q0 = *K0, q1 = *K1;
    int64_t s0 = t->stretch[(uint32_t)q0.p >> 4], s1 = t->stretch[(uint32_t)q1.p >> 4];
    for (; k < na; k++) {
        Counter *k2 = &z2[(uint64_t)act[k] % FEAT];
        int64_t s2 = t->stretch[(uint32_t)k2->p >> 4];
        if (MRC_UNLIKELY(zero_flag(free, t, s0, s1, s2, &w0, &w1, &w2, &range, &code, run))) break;
        if (sat) { /* counter_update0 of a counter at 63 */
            q0.p = (uint16_t)(q0.p - (q0.p >> 6));
            q1.p = (uint16_t)(q1.p - (q1.p >> 6));
        } else {
            counter_update0(&q0);
            counter_update0(&q1);
        }
        counter_update0(k2);
        s0 = t->stretch[(uint32_t)q0.p >> 4];
        s1 = t->stretch[(uint32_t)q1.p >> 4];
        if (MRC_UNLIKELY(range < (1u << 24))) code = dec_refill(&c->d, &range, code);
        row[act[k] * cs] = 0;
    }
    *K0 = q0;
    *K1 = q1;
    run_store(run, w0, w1, w2, range, code);
    return k;
}

/* The zero flags of a quiet row from column k on (every active column's neighbourhood zero: the contexts of
 * an all-zero neighbourhood, the counters K0 and K1 the same two for every column, kept in registers here), as
 * decode_details' loop decodes them, up to the first non-zero flag: returns its column (the flag's decision is
 * left to the caller, with run's s, p and bound), or na when the row's flags are all zero. Its own function: few
 * values live, all in registers. */
static MRC_NOINLINE int64_t quiet_run(Coder *c, Counter *K0, Counter *K1, Counter *z2, int64_t *row,
                                      const int32_t *act, int64_t k, int64_t na, int64_t cs, Run *run) {
    int free = run_free(run, na - k);
    int sat = K0->n == 63 && K1->n == 63;
    if (sat && free) return quiet_loop(1, 1, c, K0, K1, z2, row, act, k, na, cs, run);
    if (sat) return quiet_loop(1, 0, c, K0, K1, z2, row, act, k, na, cs, run);
    if (free) return quiet_loop(0, 1, c, K0, K1, z2, row, act, k, na, cs, run);
    return quiet_loop(0, 0, c, K0, K1, z2, row, act, k, na, cs, run);
}

/* busy_run's loop (`free` as quiet_loop's) */
MRC_INLINE int64_t busy_loop(const int free, Coder *c, const ColCtx *cc, int64_t k, int64_t na, Run *run) {
    const Tables *t = c->t;
    int64_t w0 = run->w[0], w1 = run->w[1], w2 = run->w[2];
    uint32_t range = run->range, code = run->code;
    for (; k < na; k++) {
        Counter *k0 = cc[k].k0, *k1 = cc[k].k1, *k2 = cc[k].k2;
        int64_t s0 = t->stretch[(uint32_t)k0->p >> 4], s1 = t->stretch[(uint32_t)k1->p >> 4];
        int64_t s2 = t->stretch[(uint32_t)k2->p >> 4];
        if (MRC_UNLIKELY(zero_flag(free, t, s0, s1, s2, &w0, &w1, &w2, &range, &code, run))) break;
        counter_update0(k0);
        counter_update0(k1);
        counter_update0(k2);
        if (MRC_UNLIKELY(range < (1u << 24))) code = dec_refill(&c->d, &range, code);
    }
    run_store(run, w0, w1, w2, range, code);
    return k;
}

/* The zero flags of a row from column k on under the contexts cc (row_contexts'), up to the first non-zero flag:
 * returns its column (the flag's decision left to the caller, as quiet_run), or na when they are all zero. */
static MRC_NOINLINE int64_t busy_run(Coder *c, const ColCtx *cc, int64_t k, int64_t na, Run *run) {
    return run_free(run, na - k) ? busy_loop(1, c, cc, k, na, run) : busy_loop(0, c, cc, k, na, run);
}

/* The details of the active features act[0..na-1] (the others, idle[0..ni-1], are written 0), level L to 1, row
 * by row: the decisions of code_body's loop. cc: na entries of scratch; nz: F bytes, whether each coefficient row
 * has a non-zero (a parent row of the band next to the approximation: whether its difference to the next does). */
static void decode_details(Coder *c, Models *m, int64_t *coef, const int32_t *act, int64_t na,
                           const int32_t *idle, int64_t ni, const int64_t *sizes, int levels, int64_t rs,
                           int64_t cs, int32_t *wzero, ColCtx *cc, uint8_t *nz) {
    int32_t wl[3] = {wzero[0], wzero[1], wzero[2]}, w[3]; /* wl: in registers (its address does not escape) */
    for (int64_t i = 0; i < sizes[0]; i++) { /* the approximation's differences: rows_of's pk2 - pk */
        int64_t i2 = i + 1 < sizes[0] - 1 ? i + 1 : sizes[0] - 1;
        nz[i] = 0;
        for (int64_t k = 0; k < na; k++) nz[i] |= coef[i * rs + act[k] * cs] != coef[i2 * rs + act[k] * cs];
    }
    int64_t start = sizes[0], pstart = 0;
    for (int b = 1; b <= levels; b++) {
        int j = levels - b + 1, bc = j <= 1 ? 0 : 1;
        int64_t n = sizes[b], np = sizes[b - 1];
        int64_t *cur = coef + start * rs;
        const int64_t *par = coef + pstart * rs;
        uint8_t *nzc = nz + start;
        const uint8_t *nzp = nz + pstart;
        Counter *z2 = m->z2 + (j < LEVELS - 1 ? j : LEVELS - 1) * m->feat;
        for (int64_t i = 0; i < n; i++) {
            Rows rw = rows_of(cur, i, par, np, b == 1, j, rs, cs);
            int64_t *row = cur + i * rs;
            int64_t k1 = (rw.pk - par) / rs, k2 = (rw.pk2 - par) / rs; /* the parent rows */
            int quiet = !(rw.has1 && nzc[i - 1]) && !(rw.has2 && nzc[i - 2]) &&
                        (b == 1 ? !nzp[k1] : !nzp[k1] && !nzp[k2]);
            int any = 0;
            for (int64_t k = 0; k < ni; k++) row[idle[k] * cs] = 0;
            uint32_t range = c->d.range, code = c->d.code;
            int64_t k = 0;
            int s[3], p = 0;
            uint32_t bound = 0;
            if (quiet) {
                Run run = {range, code, {wl[0], wl[1], wl[2]}, {0, 0, 0}, 0, 0};
                k = quiet_run(c, &m->z0[bc * N0], &m->z1[bc * N1 * N1], z2, row, act, 0, na, cs, &run);
                run_load(&run, wl, &range, &code, s, &p, &bound);
                if (k < na) row_contexts(c->t, m, &rw, row, act + k, na - k, bc, z2, cc + k);
            } else {
                row_contexts(c->t, m, &rw, row, act, na, bc, z2, cc);
            }
            while (k < na) {
                if (!quiet || any) { /* the general loop (a row with a non-zero somewhere around, or after one) */
                    Run run = {range, code, {wl[0], wl[1], wl[2]}, {0, 0, 0}, 0, 0};
                    k = busy_run(c, cc, k, na, &run);
                    run_load(&run, wl, &range, &code, s, &p, &bound);
                    if (k == na) break;
                }
                /* a non-zero at column k */
                const int64_t at = act[k] * cs;
                c->d.code = code;
                memcpy(w, wl, sizeof w);
                decode_nonzero(c, m, &rw, &cc[k], at, &row[at], k + 1 < na && act[k + 1] == act[k] + 1, bc, w, s, p,
                               bound);
                memcpy(wl, w, sizeof wl);
                range = c->d.range;
                code = c->d.code;
                any = 1;
                k++;
            }
            c->d.range = range;
            c->d.code = code;
            nzc[i] = (uint8_t)any;
        }
        pstart = start;
        start += n;
    }
    memcpy(wzero, wl, sizeof wl);
}

/* exponents, each as its difference from the previous one coded; where `active` (may be NULL) is 0 nothing is
 * coded (0 on decoding) */
MRC_INLINE int code_exponents(const int dec, Coder *c, Counter *set, int64_t *values, int64_t count,
                              const uint8_t *active) {
    int64_t last = 0;
    for (int64_t i = 0; i < count; i++) {
        if (active && !active[i]) {
            if (dec) values[i] = 0;
            continue;
        }
        int64_t v = dec ? 0 : values[i] - last;
        code_sint(dec, c, set, &v);
        if (dec) {
            if (v > 2 * MRC_MAX_EXPONENT || v < -2 * MRC_MAX_EXPONENT) return MRC_E_EXPONENT;
            values[i] = last + v;
            if (values[i] > MRC_MAX_EXPONENT || values[i] < -MRC_MAX_EXPONENT) return MRC_E_EXPONENT;
        }
        last = values[i];
    }
    return MRC_OK;
}

/* The body in both directions. Arrays: fexp (D), rexp (R), coef (F x D); on decoding they are written. */
MRC_INLINE int code_body(const int dec, const int fast, Coder *c, int64_t F, int64_t D, int64_t R, int64_t *fexp,
                         int64_t *rexp, int64_t *coef, int64_t rs, int64_t cs, int version, MrcStates *states) {
    Coder local = *c; /* a copy whose address does not escape: its fields stay in registers */
    Coder *outer = c;
    c = &local;
    Models m;
    int e = models_init(&m, D, version);
    if (e) return e;
    uint8_t *active = (uint8_t *)calloc((size_t)D, 1);
    if (!active) {
        models_free(&m);
        return MRC_E_MEMORY;
    }
    if (!dec) {
        for (int64_t f = 0; f < F; f++)
            for (int64_t d = 0; d < D; d++)
                if (coef[f * rs + d * cs]) active[d] = 1;
    }
    int prev = 1;
    for (int64_t d = 0; d < D; d++) {
        active[d] = (uint8_t)code_counter(dec, c, &m.gen[GEN_ACTIVE][prev], active[d]);
        prev = active[d];
    }
    e = code_exponents(dec, c, m.gen[GEN_FEXP], fexp, D, active);
    if (!e) e = code_exponents(dec, c, m.gen[GEN_REXP], rexp, R, NULL);
    int64_t sizes[21];
    int levels = mrc_level_sizes(F, sizes);
    /* the approximation: its first row, then differences of consecutive rows */
    for (int64_t i = 0; i < sizes[0] && !e; i++) {
        for (int64_t d = 0; d < D && !e; d++) {
            int64_t *at = &coef[i * rs + d * cs];
            if (!active[d]) {
                if (dec) *at = 0;
                continue;
            }
            int64_t before = i ? at[-rs] : 0;
            int64_t v = dec ? 0 : *at - before;
            code_sint(dec, c, m.gen[i ? GEN_DIFF : GEN_FIRST], &v);
            if (dec) {
                if (v > 0 ? before > LIMIT - v : before < -LIMIT - v) e = MRC_E_MAGNITUDE;
                else *at = before + v;
            }
        }
    }
    /* details, coarse to fine, row by row; the zero flags' weights (set 0, the most used) in local variables */
    int32_t wzero[MIX_INPUTS];
    memcpy(wzero, c->mix->w[0], sizeof wzero);
    if (dec && fast && !e) { /* decode_details: the same decisions */
        ColCtx *cc = (ColCtx *)malloc((size_t)D * (sizeof(ColCtx) + sizeof(int32_t)) + (size_t)F);
        if (!cc) e = MRC_E_MEMORY;
        else {
            int32_t *act = (int32_t *)(void *)(cc + D), *idle = act + D; /* act[0..na-1], idle[-ni..-1] */
            int64_t na = 0, ni = 0;
            for (int64_t d = 0; d < D; d++) {
                if (active[d]) act[na++] = (int32_t)d;
                else *(idle - ++ni) = (int32_t)d;
            }
            decode_details(c, &m, coef, act, na, idle - ni, ni, sizes, levels, rs, cs, wzero, cc,
                           (uint8_t *)(void *)idle);
            free(cc);
        }
        levels = 0; /* done: the loop below does nothing */
    }
    int64_t start = sizes[0], pstart = 0;
    for (int b = 1; b <= levels && !e; b++) {
        int j = levels - b + 1;
        int64_t n = sizes[b], np = sizes[b - 1];
        int64_t *cur = coef + start * rs;
        const int64_t *par = coef + pstart * rs;
        for (int64_t i = 0; i < n; i++) {
            Rows rw = rows_of(cur, i, par, np, b == 1, j, rs, cs);
            int64_t *row = cur + i * rs, r1 = 0;
            for (int64_t d = 0; d < D; d++) {
                if (!active[d]) {
                    if (dec) row[d * cs] = 0;
                    r1 = 0;
                    continue;
                }
                r1 = code_detail(dec, c, &m, row, &rw, d, r1, wzero);
            }
        }
        pstart = start;
        start += n;
    }
    memcpy(c->mix->w[0], wzero, sizeof wzero);
    *outer = local;
    if (states && !e) { /* the final states of the fixed counters (mrc_states) */
        Span sp[7];
        fixed_spans(&m, sp);
        int idx = 0;
        for (int a = 0; a < 7; a++)
            for (int i = 0; i < sp[a].count; i++, idx++) {
                states->stretch[idx] = c->t->stretch[counter_p12(&sp[a].at[i])];
                states->count[idx] = sp[a].at[i].n;
            }
    }
    free(active);
    models_free(&m);
    return e;
}

/* the body's two directions, each its own compiled copy */
static int code_body_enc(Coder *c, int64_t F, int64_t D, int64_t R, int64_t *fexp, int64_t *rexp, int64_t *coef,
                         int version, MrcStates *states) {
    return code_body(0, 0, c, F, D, R, fexp, rexp, coef, D, 1, version, states);
}

static int code_body_dec(Coder *c, int64_t F, int64_t D, int64_t R, int64_t *fexp, int64_t *rexp, int64_t *coef,
                         int64_t rs, int64_t cs, int version) {
    return code_body(1, 1, c, F, D, R, fexp, rexp, coef, rs, cs, version, NULL);
}

static int code_body_dec_reference(Coder *c, int64_t F, int64_t D, int64_t R, int64_t *fexp, int64_t *rexp,
                                   int64_t *coef, int64_t rs, int64_t cs, int version) {
    return code_body(1, 0, c, F, D, R, fexp, rexp, coef, rs, cs, version, NULL);
}

int mrc_encode(int64_t F, int64_t D, int64_t region, const int64_t *fexp, const int64_t *rexp,
               const int64_t *coef, uint8_t **out, size_t *out_len) {
    return mrc_encode_version(2, F, D, region, fexp, rexp, coef, out, out_len);
}

static int encode_states(int version, int64_t F, int64_t D, int64_t region, const int64_t *fexp, const int64_t *rexp,
                         const int64_t *coef, uint8_t **out, size_t *out_len, MrcStates *states);

int mrc_encode_version(int version, int64_t F, int64_t D, int64_t region, const int64_t *fexp, const int64_t *rexp,
                       const int64_t *coef, uint8_t **out, size_t *out_len) {
    return encode_states(version, F, D, region, fexp, rexp, coef, out, out_len, NULL);
}

int mrc_states(int64_t F, int64_t D, int64_t region, const int64_t *fexp, const int64_t *rexp, const int64_t *coef,
               int16_t *stretch, uint16_t *count) {
    MrcStates states = {stretch, count};
    uint8_t *out = NULL;
    size_t len = 0;
    int e = encode_states(2, F, D, region, fexp, rexp, coef, &out, &len, &states);
    free(out);
    return e;
}

static int encode_states(int version, int64_t F, int64_t D, int64_t region, const int64_t *fexp, const int64_t *rexp,
                         const int64_t *coef, uint8_t **out, size_t *out_len, MrcStates *states) {
    *out = NULL;
    *out_len = 0;
    if (F < 1 || F > MRC_MAX_FRAMES || D < 1 || D > MRC_MAX_FEATURES || region < 1 || region > MRC_MAX_REGION ||
        (version != 2 && version != 3))
        return MRC_E_ARGUMENT;
    int64_t R = count_regions(F, region);
    for (int64_t d = 0; d < D; d++)
        if (fexp[d] > MRC_MAX_EXPONENT || fexp[d] < -MRC_MAX_EXPONENT) return MRC_E_ARGUMENT;
    for (int64_t r = 0; r < R; r++)
        if (rexp[r] > MRC_MAX_EXPONENT || rexp[r] < -MRC_MAX_EXPONENT) return MRC_E_ARGUMENT;
    for (int64_t i = 0; i < F * D; i++)
        if (coef[i] > LIMIT || coef[i] < -LIMIT) return MRC_E_ARGUMENT;
    /* the body codes into a copy (code_detail writes the values it codes back, unchanged) */
    int64_t *work = (int64_t *)malloc((size_t)(F * D) * sizeof(int64_t));
    int64_t *fx = (int64_t *)malloc((size_t)D * sizeof(int64_t));
    int64_t *rx = (int64_t *)malloc((size_t)R * sizeof(int64_t));
    Tables *t = (Tables *)malloc(sizeof(Tables));
    Enc enc;
    enc_init(&enc);
    int e = MRC_OK;
    if (!work || !fx || !rx || !t) e = MRC_E_MEMORY;
    if (!e) {
        memcpy(work, coef, (size_t)(F * D) * sizeof(int64_t));
        memcpy(fx, fexp, (size_t)D * sizeof(int64_t));
        memcpy(rx, rexp, (size_t)R * sizeof(int64_t));
        tables_init(t);
        Coder c;
        Mixer mix;
        memset(&c, 0, sizeof c);
        c.enc = &enc;
        c.t = t;
        c.mix = &mix;
        mixer_init(&mix);
        e = code_body_enc(&c, F, D, R, fx, rx, work, version, states);
        if (!e) enc_finish(&enc);
        if (!e && enc.err) e = enc.err;
    }
    free(work);
    free(fx);
    free(rx);
    free(t);
    if (e) {
        free(enc.buf);
        return e;
    }
    uint8_t headb[16];
    size_t h = write_varint(headb, (uint64_t)(F - 1));
    h += write_varint(headb + h, (uint64_t)(D - 1));
    h += write_varint(headb + h, (uint64_t)(region - 1));
    size_t total = h + enc.len;
    /* zero bytes at the end (the decoder reads zeros past the end in any case) until the values fit */
    int64_t values = F * D + D + R;
    size_t need = (size_t)((values + MRC_VALUES_PER_BYTE - 1) / MRC_VALUES_PER_BYTE);
    if (total < need) total = need;
    uint8_t *buf = (uint8_t *)calloc(total ? total : 1, 1);
    if (!buf) {
        free(enc.buf);
        return MRC_E_MEMORY;
    }
    memcpy(buf, headb, h);
    if (enc.len) memcpy(buf + h, enc.buf, enc.len);
    free(enc.buf);
    *out = buf;
    *out_len = total;
    return MRC_OK;
}

int mrc_decode(const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef) {
    return mrc_decode_version(2, data, len, fexp, rexp, coef, 0);
}

int mrc_decode_layout(const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                      int feature_major) {
    return mrc_decode_version(2, data, len, fexp, rexp, coef, feature_major);
}

static int decode_with(int reference, int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp,
                       int64_t *coef, int feature_major);

int mrc_decode_version(int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                       int feature_major) {
    return decode_with(0, version, data, len, fexp, rexp, coef, feature_major);
}

int mrc_decode_reference(int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp, int64_t *coef,
                         int feature_major) {
    return decode_with(1, version, data, len, fexp, rexp, coef, feature_major);
}

/* The decoder's tables are the same for every payload: made once per process and then shared, read-only, by every
 * call and thread (14 us a decode otherwise); a compiler without GCC's atomics makes them in each call. Returns
 * the shared tables, or *own (malloc'ed here; NULL when out of memory). */
#if defined(__GNUC__)
static Tables shared_tables;
static int shared_state; /* 0: not made, 1: being made by one thread, 2: ready */
#endif

static const Tables *decoder_tables(Tables **own) {
    *own = NULL;
#if defined(__GNUC__)
    if (__atomic_load_n(&shared_state, __ATOMIC_ACQUIRE) == 2) return &shared_tables;
    int expected = 0;
    if (__atomic_compare_exchange_n(&shared_state, &expected, 1, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
        tables_init(&shared_tables);
        __atomic_store_n(&shared_state, 2, __ATOMIC_RELEASE);
        return &shared_tables;
    }
#endif
    *own = (Tables *)malloc(sizeof(Tables));
    if (*own) tables_init(*own);
    return *own;
}

static int decode_with(int reference, int version, const uint8_t *data, size_t len, int64_t *fexp, int64_t *rexp,
                       int64_t *coef, int feature_major) {
    if (version != 2 && version != 3) return MRC_E_ARGUMENT;
    int64_t F, D, region;
    size_t body;
    int e = head(data, len, &F, &D, &region, &body);
    if (e) return e;
    if (!values_fit(F, D, region, len)) return MRC_E_TOO_MANY;
    Tables *own;
    const Tables *t = decoder_tables(&own);
    if (!t) return MRC_E_MEMORY;
    Coder c;
    Mixer mix;
    c.enc = NULL;
    dec_init(&c.d, data + body, len - body);
    c.t = t;
    c.mix = &mix;
    mixer_init(&mix);
    e = (reference ? code_body_dec_reference : code_body_dec)(&c, F, D, count_regions(F, region), fexp, rexp, coef,
                                                              feature_major ? 1 : D, feature_major ? F : 1, version);
    free(own);
    if (e) return e;
    /* the decoder reads as many bytes as the encoder wrote, of which at most the last 5 (the ending) are
     * dropped zeros; every byte read, and what was not read must be zero padding */
    if (c.d.pos > c.d.len + 5) return MRC_E_TRUNCATED;
    for (size_t i = c.d.pos; i < c.d.len; i++)
        if (data[body + i]) return MRC_E_TRAILING;
    return MRC_OK;
}
