/* The whitespace-separated numbers of a byte block in one pass (motionrep/io/_numbers.py explains the method).
 *
 * One loop over the bytes finds the tokens (runs of bytes > 32), counts them per line and parses each where it
 * stands: an optional sign, digits with at most one '.', an optional exponent.  While the integer of the digits is
 * below 2**53 and the power of ten is at most 22 in size, both are exact doubles and one correctly rounded
 * multiplication or division gives the correctly rounded value of the decimal (Clinger's fast path): float()'s
 * answer.  Any other token is left to Python's float: NaN is stored and its place recorded in `fallback`. */
#include <math.h>

#include "ccore.h"

static const double POW10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* Parse the token at u[s] (a byte > 32).  Returns 1 and *v on the fast path, else 0; *end: the offset after it. */
static inline int parse_token(const uint8_t *u, int64_t s, int64_t n, double *v, int64_t *end)
{
    int64_t i = s;
    int negative = 0;
    if (u[i] == '-' || u[i] == '+') {
        negative = u[i] == '-';
        i++;
    }
    int64_t mantissa = 0, digits = 0, decimals = 0;
    int exact = 1;
    while (i < n && u[i] >= '0' && u[i] <= '9') {
        if (mantissa >= 900719925474099) /* one more digit could reach 2**53 */
            exact = 0;
        else
            mantissa = mantissa * 10 + (u[i] - '0');
        digits++;
        i++;
    }
    if (i < n && u[i] == '.') {
        i++;
        while (i < n && u[i] >= '0' && u[i] <= '9') {
            if (mantissa >= 900719925474099)
                exact = 0;
            else
                mantissa = mantissa * 10 + (u[i] - '0');
            decimals++;
            digits++;
            i++;
        }
    }
    int64_t exponent = 0;
    if (digits && i < n && (u[i] == 'e' || u[i] == 'E')) {
        i++;
        int negative_exponent = 0;
        if (i < n && (u[i] == '-' || u[i] == '+')) {
            negative_exponent = u[i] == '-';
            i++;
        }
        int64_t exponent_digits = 0;
        while (i < n && u[i] >= '0' && u[i] <= '9') {
            if (exponent < 100000)
                exponent = exponent * 10 + (u[i] - '0');
            exponent_digits++;
            i++;
        }
        if (exponent_digits == 0)
            exact = 0;
        if (negative_exponent)
            exponent = -exponent;
    }
    if (i < n && u[i] > 32) { /* more bytes: not a plain decimal number (Python's float decides) */
        while (i < n && u[i] > 32)
            i++;
        *end = i;
        return 0;
    }
    *end = i;
    int64_t power = exponent - decimals;
    if (digits == 0 || !exact || power > 22 || power < -22)
        return 0;
    double x = (double)mantissa; /* exact: below 2**53 */
    x = power >= 0 ? x * POW10[power] : x / POW10[-power];
    *v = negative ? -x : x;
    return 1;
}

/* by_line: rows of `width` values, one per line with tokens (token k of row r at out[r * width + k]; rows from
 * rows_max on and tokens past width are counted, not stored); otherwise every token in order (at most out_size).
 * A token off the fast path gets NaN and (slot, start, end, line) in fallback (the first `capacity` of them). */
void mr_scan(const uint8_t *u, int64_t n, int64_t width, int64_t rows_max, int by_line, double *out,
             int64_t out_size, int64_t *fallback, int64_t capacity, int64_t *info)
{
    int64_t line = 0, rows = 0, count = 0, row = -1, tokens = 0, left = 0;
    int64_t first_wrong = -1, wrong_count = 0, last_data = -1, extra = -1, first_data = -1;
    int64_t i = 0;
    while (i <= n) {
        if (i == n || u[i] == '\n') { /* end of a line */
            if (by_line && count > 0 && count != width && first_wrong < 0) {
                first_wrong = line;
                wrong_count = count;
            }
            count = 0;
            line++;
            i++;
            continue;
        }
        if (u[i] <= 32) {
            i++;
            continue;
        }
        int64_t s = i, slot = -1;
        if (by_line) {
            if (count == 0) {
                row = rows;
                rows++;
                last_data = line;
                if (first_data < 0)
                    first_data = line;
                if (row == rows_max)
                    extra = line;
            }
            if (row < rows_max && count < width)
                slot = row * width + count;
            count++;
        } else if (tokens < out_size) {
            slot = tokens;
        }
        tokens++;
        double v = 0.0;
        int ok = parse_token(u, s, n, &v, &i);
        if (slot < 0)
            continue;
        if (ok) {
            out[slot] = v;
        } else {
            out[slot] = NAN;
            if (left < capacity) {
                fallback[4 * left] = slot;
                fallback[4 * left + 1] = s;
                fallback[4 * left + 2] = i;
                fallback[4 * left + 3] = line;
            }
            left++;
        }
    }
    info[MR_ROWS] = rows;
    info[MR_FIRST_WRONG] = first_wrong;
    info[MR_WRONG_COUNT] = wrong_count;
    info[MR_LAST_DATA] = last_data;
    info[MR_EXTRA] = extra;
    info[MR_FIRST_DATA] = first_data;
    info[MR_FALLBACKS] = left;
    info[MR_TOKENS] = tokens;
}
