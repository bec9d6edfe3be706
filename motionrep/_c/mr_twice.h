/* Include the file named by MR_IMPL twice: its functions compiled for the x86-64 baseline (MR_FN(name) is
 * name_baseline) and for AVX2 (name_avx2).  The two give the same bits (the same IEEE operations; target("avx2")
 * enables no fused multiply-add, and -ffp-contract=off forbids it anyway); AVX2 only does four values at once.
 * ccore.h's mr_simd says which runs.  No include guard: a file includes this once per MR_IMPL. */
#define MR_FN(name) name##_baseline
#include MR_IMPL
#undef MR_FN

#if MR_HAVE_AVX2
#pragma GCC push_options
#pragma GCC target("avx2")
#define MR_FN(name) name##_avx2
#include MR_IMPL
#undef MR_FN
#pragma GCC pop_options
#endif

#undef MR_IMPL
