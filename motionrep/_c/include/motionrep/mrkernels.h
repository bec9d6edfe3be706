/* motionrep's shared C kernels: the arithmetic every compiled decoder of the project uses, written once.
 *
 * Header only (static inline), installed with the package (motionrep/_c/include) so that a plugin's extension can
 * include it: the shipped svd and Fourier decoders and the pose plan (motionrep._cplan) do.
 *
 * Determinism: every function here uses IEEE basic operations only (+, -, *, /, sqrt, floor), in a fixed order.
 * Compile with -ffp-contract=off and without -ffast-math (setup.py does): then a value is the same bits in a
 * vector lane or a scalar one, at any position in a batch, on any x86-64 or aarch64 CPU.  MR_CLONES asks gcc for
 * an AVX2 and an AVX-512 copy of a kernel beside the baseline one (chosen at load time by the CPU); the copies
 * compute the same bits, they only hold more lanes.
 */
#ifndef MOTIONREP_MRKERNELS_H
#define MOTIONREP_MRKERNELS_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && !defined(MR_NO_CLONES)
#define MR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define MR_CLONES
#endif

#if defined(__GNUC__)
#define MR_INLINE static inline __attribute__((always_inline))
#define MR_RESTRICT __restrict__
#else
#define MR_INLINE static inline
#define MR_RESTRICT
#endif

/* The conversions to quaternions and their sine and cosine, one value at a time (mr_sincos, mr_product,
 * mr_axis_angle, mr_normalized, mr_euler_factor, mr_ortho6d): the compiled core's header, one implementation for
 * every extension (installed with the package beside this folder). */
#define MR_ROTCONV_FLOOR_BUILTIN
#include "../../mr_rotconv.h"

/* Z[u * ldz + i] = b[u] + sum_k W[u * K + k] X[k * ldx + i] for u < U, i < m: a dense layer on a block of m inputs
 * stored as columns, each sum in a fixed order (bias first, then k = 0, 1, ..., one multiply and one add at a
 * time), vectorised over the block's columns, never over the sum: an input gives the same bits in any block, at
 * any position (compare mr_affine_one_*), on any CPU.  Four units at a time and two inputs per pass, as
 * motionrep.jit.affine_block (the same operations in the same order). */
#define MR_AFFINE_BLOCK(NAME, T)                                                                                   \
    MR_INLINE void NAME(const T *MR_RESTRICT W, ptrdiff_t U, ptrdiff_t K, const T *MR_RESTRICT b,                 \
                        const T *MR_RESTRICT X, ptrdiff_t ldx, T *MR_RESTRICT Z, ptrdiff_t ldz, ptrdiff_t m)      \
    {                                                                                                             \
        ptrdiff_t u = 0;                                                                                          \
        for (; u + 4 <= U; u += 4) {                                                                              \
            T *z0 = Z + u * ldz, *z1 = z0 + ldz, *z2 = z1 + ldz, *z3 = z2 + ldz;                                  \
            const T *w0 = W + u * K, *w1 = w0 + K, *w2 = w1 + K, *w3 = w2 + K;                                    \
            T b0 = b[u], b1 = b[u + 1], b2 = b[u + 2], b3 = b[u + 3];                                            \
            for (ptrdiff_t i = 0; i < m; i++) {                                                                   \
                z0[i] = b0; z1[i] = b1; z2[i] = b2; z3[i] = b3;                                                   \
            }                                                                                                     \
            ptrdiff_t k = 0;                                                                                      \
            for (; k + 2 <= K; k += 2) {                                                                          \
                T w00 = w0[k], w01 = w0[k + 1], w10 = w1[k], w11 = w1[k + 1];                                    \
                T w20 = w2[k], w21 = w2[k + 1], w30 = w3[k], w31 = w3[k + 1];                                    \
                const T *xa = X + k * ldx, *xb = xa + ldx;                                                        \
                for (ptrdiff_t i = 0; i < m; i++) {                                                               \
                    T x0 = xa[i], x1 = xb[i];                                                                     \
                    z0[i] = (z0[i] + w00 * x0) + w01 * x1;                                                        \
                    z1[i] = (z1[i] + w10 * x0) + w11 * x1;                                                        \
                    z2[i] = (z2[i] + w20 * x0) + w21 * x1;                                                        \
                    z3[i] = (z3[i] + w30 * x0) + w31 * x1;                                                        \
                }                                                                                                 \
            }                                                                                                     \
            if (k < K) {                                                                                          \
                T v0 = w0[k], v1 = w1[k], v2 = w2[k], v3 = w3[k];                                                 \
                const T *xa = X + k * ldx;                                                                        \
                for (ptrdiff_t i = 0; i < m; i++) {                                                               \
                    T x = xa[i];                                                                                  \
                    z0[i] += v0 * x; z1[i] += v1 * x; z2[i] += v2 * x; z3[i] += v3 * x;                           \
                }                                                                                                 \
            }                                                                                                     \
        }                                                                                                         \
        for (; u < U; u++) {                                                                                      \
            T *z = Z + u * ldz;                                                                                   \
            const T *w = W + u * K;                                                                               \
            T bias = b[u];                                                                                        \
            for (ptrdiff_t i = 0; i < m; i++) z[i] = bias;                                                        \
            for (ptrdiff_t k = 0; k < K; k++) {                                                                   \
                T wk = w[k];                                                                                      \
                const T *xa = X + k * ldx;                                                                        \
                for (ptrdiff_t i = 0; i < m; i++) z[i] += wk * xa[i];                                             \
            }                                                                                                     \
        }                                                                                                         \
    }

/* The same sums as MR_AFFINE_BLOCK (each in the same order: the same bits), with each tile of eight units by 64
 * bytes of columns keeping its sums in registers over the whole of k (gcc's vector extension, lowered to the
 * vectors each target copy has), and the results stored converted to TO (exactly: float to double, or the same
 * type): faster for blocks of 16 or more columns (the svd decoder's 64), slower on a block's last few columns
 * (summed one at a time), so the Fourier decoder, whose blocks are its windows' times, keeps MR_AFFINE_BLOCK.
 * `rows` (or NULL: u): the row of Z unit u's sums go to, Z + rows[u] * ldz (the svd decoder leaves out the
 * features of zero weights). */
#define MR_ROW(rows, u) ((rows) ? (rows)[u] : (u))
#if defined(__GNUC__)
#define MR_AFFINE_BLOCK_TO(NAME, T, TO)                                                                            \
    MR_INLINE void NAME(const T *MR_RESTRICT W, ptrdiff_t U, ptrdiff_t K, const T *MR_RESTRICT b,                 \
                        const T *MR_RESTRICT X, ptrdiff_t ldx, TO *MR_RESTRICT Z, ptrdiff_t ldz, ptrdiff_t m,     \
                        const ptrdiff_t *MR_RESTRICT rows)                                                        \
    {                                                                                                             \
        typedef T vec __attribute__((vector_size(64)));                                                          \
        typedef TO tovec __attribute__((vector_size(64 / sizeof(T) * sizeof(TO))));                              \
        enum { L = 64 / sizeof(T), UT = 8 };                                                                     \
        /* a vector times a scalar: the scalar in every lane (w x = x w exactly); 1 b is b exactly */              \
        const vec one = (vec){} + (T)1;                                                                           \
        ptrdiff_t i = 0;                                                                                          \
        for (; i + L <= m; i += L) {                                                                              \
            ptrdiff_t u = 0;                                                                                      \
            for (; u + UT <= U; u += UT) { /* UT units by L columns, the sums in registers over the whole of k */ \
                vec acc[UT];                                                                                      \
                for (int q = 0; q < UT; q++)                                                                      \
                    acc[q] = one * b[u + q];                                                                      \
                for (ptrdiff_t k = 0; k < K; k++) {                                                               \
                    vec x;                                                                                        \
                    memcpy(&x, X + k * ldx + i, sizeof x);                                                        \
                    for (int q = 0; q < UT; q++)                                                                  \
                        acc[q] = acc[q] + x * W[(u + q) * K + k];                                                 \
                }                                                                                                 \
                for (int q = 0; q < UT; q++) {                                                                    \
                    tovec t = __builtin_convertvector(acc[q], tovec);                                             \
                    memcpy(Z + MR_ROW(rows, u + q) * ldz + i, &t, sizeof t);                                            \
                }                                                                                                 \
            }                                                                                                     \
            for (; u < U; u++) { /* the last units, one at a time */                                              \
                vec acc = one * b[u];                                                                             \
                for (ptrdiff_t k = 0; k < K; k++) {                                                               \
                    vec x;                                                                                        \
                    memcpy(&x, X + k * ldx + i, sizeof x);                                                        \
                    acc = acc + x * W[u * K + k];                                                                 \
                }                                                                                                 \
                tovec t = __builtin_convertvector(acc, tovec);                                                    \
                memcpy(Z + MR_ROW(rows, u) * ldz + i, &t, sizeof t);                                                      \
            }                                                                                                     \
        }                                                                                                         \
        for (ptrdiff_t u = 0; i < m && u < U; u++) { /* the last columns */                                       \
            for (ptrdiff_t c = i; c < m; c++) {                                                                   \
                T s = b[u];                                                                                       \
                for (ptrdiff_t k = 0; k < K; k++)                                                                 \
                    s = s + W[u * K + k] * X[k * ldx + c];                                                        \
                Z[MR_ROW(rows, u) * ldz + c] = (TO)s;                                                                     \
            }                                                                                                     \
        }                                                                                                         \
    }
#else
#define MR_AFFINE_BLOCK_TO(NAME, T, TO)                                                                            \
    MR_INLINE void NAME(const T *MR_RESTRICT W, ptrdiff_t U, ptrdiff_t K, const T *MR_RESTRICT b,                 \
                        const T *MR_RESTRICT X, ptrdiff_t ldx, TO *MR_RESTRICT Z, ptrdiff_t ldz, ptrdiff_t m,     \
                        const ptrdiff_t *MR_RESTRICT rows)                                                        \
    {                                                                                                             \
        for (ptrdiff_t u = 0; u < U; u++)                                                                         \
            for (ptrdiff_t i = 0; i < m; i++) {                                                                   \
                T s = b[u];                                                                                       \
                for (ptrdiff_t k = 0; k < K; k++)                                                                 \
                    s = s + W[u * K + k] * X[k * ldx + i];                                                        \
                Z[MR_ROW(rows, u) * ldz + i] = (TO)s;                                                                     \
            }                                                                                                     \
    }
#endif

/* z[u] = b[u] + sum_k WT[k * U + u] x[k]: mr_affine_block for one input (the same sums, the same order), vectorised
 * over the units instead, with the transposed weights WT (K, U), as motionrep.jit.affine_one. */
#define MR_AFFINE_ONE(NAME, T)                                                                                     \
    MR_INLINE void NAME(const T *MR_RESTRICT WT, ptrdiff_t U, ptrdiff_t K, const T *MR_RESTRICT b,                \
                        const T *MR_RESTRICT x, T *MR_RESTRICT z)                                                 \
    {                                                                                                             \
        for (ptrdiff_t u = 0; u < U; u++) z[u] = b[u];                                                            \
        for (ptrdiff_t k = 0; k < K; k++) {                                                                       \
            T xk = x[k];                                                                                          \
            const T *w = WT + k * U;                                                                              \
            for (ptrdiff_t u = 0; u < U; u++) z[u] += w[u] * xk;                                                  \
        }                                                                                                         \
    }

MR_AFFINE_BLOCK(mr_affine_block_f64, double)
MR_AFFINE_BLOCK(mr_affine_block_f32, float)
MR_AFFINE_BLOCK_TO(mr_affine_block_f64_to, double, double)
MR_AFFINE_BLOCK_TO(mr_affine_block_f32_f64, float, double)
MR_AFFINE_ONE(mr_affine_one_f64, double)
MR_AFFINE_ONE(mr_affine_one_f32, float)

/* Python's min(a, b) and max(a, b) on floats, as the numba kernels computed them (NaN propagates from the first
 * argument the same way). */
/* pi as a double: the same bits as numpy.pi and math.pi */
#define MR_PI 3.141592653589793

#define MR_PYMIN(a, b) (((b) < (a)) ? (b) : (a))
#define MR_PYMAX(a, b) (((b) > (a)) ? (b) : (a))

#endif
