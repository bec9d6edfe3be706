/* BVH frame values as text in one pass: each value as the shortest decimal that reads back to the same double.
 *
 * 1. The fewest decimals d (at most 17) with an integer m < 2**53 such that m / 10**d == |x| (one correctly
 *    rounded division of two exact doubles, so what every correct reader returns for the decimal): m's digits in
 *    fixed point, '-' for a negative value (-0 too).
 * 2. Otherwise repr's digits, computed exactly where that is easy to be sure of: a normal value with
 *    1e-3 <= |x| < 2**52 whose significand is not a power of two (its rounding interval is symmetric).  With
 *    x = f 2**-s, x 10**k is f 10**k / 2**s, a 128-bit product shifted; for n = 16, 15, ... significant digits the
 *    nearest decimal D 10**-k is taken and it reads back as x iff |D 2**(s+1) - 2 f 10**k| < 10**k (inside the
 *    half-ulp interval): the shortest n that does is repr's length, and the nearest of that length is the one
 *    repr writes (David Gay's shortest mode).  Written positionally, as repr does for 1e-4 <= |x| < 1e16.
 * 3. Anything else (ties, a boundary hit exactly, a power-of-two significand, other magnitudes) is left to Python's
 *    repr: its place in the output is recorded and the caller splices it in.
 * motionrep/io/_shortest.py is the caller; tests/test_io_bvh_writer.py checks the bytes against repr and float. */
#include <math.h>
#include <string.h>

#include "ccore.h"
#include "mr_rotconv.h"

__extension__ typedef unsigned __int128 u128;

static const double POW10F[18] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,
                                  1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17};
static const uint64_t POW10U[20] = {1ULL,
                                    10ULL,
                                    100ULL,
                                    1000ULL,
                                    10000ULL,
                                    100000ULL,
                                    1000000ULL,
                                    10000000ULL,
                                    100000000ULL,
                                    1000000000ULL,
                                    10000000000ULL,
                                    100000000000ULL,
                                    1000000000000ULL,
                                    10000000000000ULL,
                                    100000000000000ULL,
                                    1000000000000000ULL,
                                    10000000000000000ULL,
                                    100000000000000000ULL,
                                    1000000000000000000ULL,
                                    10000000000000000000ULL};
#define MAX_SAFE 9007199254740992.0 /* 2**53 */
#define FRACTION ((1ULL << 52) - 1)
#define HIDDEN (1ULL << 52)

/* The `count` lowest decimal digits of x at out[pos:pos + count]. */
static inline void put_digits(uint8_t *out, int64_t pos, uint64_t x, int64_t count)
{
    for (int64_t i = count - 1; i >= 0; i--) {
        uint64_t q = x / 10;
        out[pos + i] = (uint8_t)(x - q * 10 + '0');
        x = q;
    }
}

/* The nearest decimal of n significant digits to a = f 2**-s (decimal exponent E) is D 10**(E + 1 - n): returns 1
 * if it reads back as a, 0 if not, 2 if this cannot be sure (a tie, the interval's boundary, E off by one). */
static inline int nearest(uint64_t f, int s, int64_t E, int n, uint64_t mask, uint64_t half, uint64_t *D_out)
{
    uint64_t p = POW10U[n - 1 - E];
    u128 prod = (u128)f * p;
    uint64_t q = (uint64_t)(prod >> s);
    uint64_t r = (uint64_t)prod & mask;
    if (r == half)
        return 2;
    uint64_t D = r > half ? q + 1 : q;
    if (D < POW10U[n - 1] || D >= POW10U[n])
        return 2; /* E is off by one (near a power of ten), or the nearest is 10**n */
    u128 a = (u128)D << (s + 1), b = prod << 1;
    u128 diff = a >= b ? a - b : b - a;
    if (diff == (u128)p)
        return 2;
    *D_out = D;
    return diff < (u128)p;
}

/* repr's shortest digits D (n of them, returned; 0 where this cannot be sure) of a > 0 and its decimal exponent
 * *E (a is about D 10**(E + 1 - n)).  Whether n digits suffice is monotone in n (a shorter decimal padded with
 * zeros is a longer one), so the search starts at 16 (most values that get here need 16 or 17) and walks down. */
static inline int repr_digits(double a, uint64_t *D_out, int64_t *E_out)
{
    if (!(1e-3 <= a && a < 4503599627370496.0))
        return 0;
    uint64_t bits;
    memcpy(&bits, &a, sizeof bits);
    if ((bits & FRACTION) == 0)
        return 0;
    uint64_t f = (bits & FRACTION) | HIDDEN;
    int s = 1075 - (int)(bits >> 52); /* a = f 2**-s, 1 <= s <= 62 in this range */
    int64_t E = (int64_t)floor(log10(a));
    if (E < -3 || E > 14)
        return 0;
    int64_t low = E + 2 < 1 ? 1 : E + 2; /* fewer digits would make a whole number (those have d >= 0) */
    uint64_t mask = (1ULL << s) - 1, half = 1ULL << (s - 1);
    uint64_t D = 0, shorter = 0;
    int status = nearest(f, s, E, 16, mask, half, &D);
    if (status == 2)
        return 0;
    if (status == 0) {
        if (nearest(f, s, E, 17, mask, half, &D) != 1)
            return 0;
        *D_out = D;
        *E_out = E;
        return 17;
    }
    int n = 16, stopped = 0;
    while (n > low) {
        status = nearest(f, s, E, n - 1, mask, half, &shorter);
        if (status == 2)
            return 0;
        if (status == 0) {
            stopped = 1;
            break;
        }
        D = shorter;
        n--;
    }
    if (!stopped)
        return 0; /* n digits suffice down to the search's start: a shorter one might exist below it */
    while (D % 10 == 0) { /* not expected at the shortest length; repr writes none */
        D /= 10;
        n--;
    }
    if (n <= E + 1)
        return 0; /* a whole number: repr writes '.0' (not expected: it has d >= 0) */
    *D_out = D;
    *E_out = E;
    return n;
}

/* flat's `count` values, `per_line` a line, into out (MR_SHORTEST_WIDTH bytes of room each): returns the length;
 * *left values are left to repr, the first `capacity` of them as (offset in out, value index) in fallback. */
int64_t mr_format_shortest(const double *flat, int64_t count, int64_t per_line, uint8_t *out, int64_t *fallback,
                           int64_t capacity, int64_t *left)
{
    int64_t pos = 0, nleft = 0;
    for (int64_t i = 0; i < count; i++) {
        double v = flat[i];
        double a = fabs(v);
        int negative = signbit(v) != 0;
        double small = MAX_SAFE < a ? MAX_SAFE : a;
        int64_t d = -1;
        double m = 0.0;
        for (int k = 0; k < 18; k++) {
            double cand = mr_rint_nonneg(small * POW10F[k]);
            if (cand < MAX_SAFE && cand / POW10F[k] == a) {
                d = k;
                m = cand;
                break;
            }
        }
        if (d >= 0) {
            if (negative)
                out[pos++] = '-';
            uint64_t mi = (uint64_t)m;
            uint64_t whole = mi / POW10U[d];
            int64_t digits = 1;
            while (digits < 17 && whole >= POW10U[digits])
                digits++;
            put_digits(out, pos, whole, digits);
            pos += digits;
            if (d > 0) {
                out[pos] = '.';
                put_digits(out, pos + 1, mi - whole * POW10U[d], d);
                pos += d + 1;
            }
        } else {
            uint64_t D = 0;
            int64_t E = 0;
            int n = repr_digits(a, &D, &E);
            if (n == 0) {
                if (nleft < capacity) {
                    fallback[2 * nleft] = pos;
                    fallback[2 * nleft + 1] = i;
                }
                nleft++;
            } else {
                if (negative)
                    out[pos++] = '-';
                if (E >= 0) {
                    int64_t frac = n - (E + 1);
                    put_digits(out, pos, D / POW10U[frac], E + 1);
                    out[pos + E + 1] = '.';
                    put_digits(out, pos + E + 2, D % POW10U[frac], frac);
                    pos += n + 1;
                } else {
                    out[pos] = '0';
                    out[pos + 1] = '.';
                    for (int64_t z = 0; z < -E - 1; z++)
                        out[pos + 2 + z] = '0';
                    pos += 1 - E;
                    put_digits(out, pos, D, n);
                    pos += n;
                }
            }
        }
        out[pos++] = i % per_line == per_line - 1 ? '\n' : ' ';
    }
    *left = nleft;
    return pos;
}
