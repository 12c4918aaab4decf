/* sensorcfg's optional compiled kernels, loaded by sensorcfg/compiled.py (`MODULE`); where they are not built,
 * or SENSORCFG_NUMPY_STREAMS=1, numpy does the same work and gives the same bits. Each entry point, what it
 * does, its arguments, its Python caller and the test that pins it against numpy:
 *
 * - add(keys, samples, size, lanes, out, width, lo, rows, accumulate): the counter-based noise numbers of
 *   sensorcfg.noise.streams for m samples (keys (m, 2) uint64: each sample's episode key; samples (m,) int64;
 *   `size` values each), up to 8 lanes (tag, normal, scale or None, offset or None: one stage's numbers,
 *   scaled and shifted) summed per value and written, or added (`accumulate`), into out[rows[r], lo:lo + size]
 *   (out (n, width) float64; rows None: row r; width 0: out flat, rows[r] where sample r's values start).
 *   Called by noise/streams.py (`numbers`, `add_sums`, `add_rows`, on two threads through `compiled.split`);
 *   pinned by tests/noise/test_streams.py::test_the_compiled_kernel_gives_the_numpy_numbers_bit_for_bit,
 *   test_sums_added_in_place_equal_the_numpy_arithmetic_on_both_paths, test_sums_written_replace_the_rows,
 *   test_prepared_rows_add_what_add_sums_adds (and test_the_kernel_refuses_rows_outside_its_table).
 * - tables(kn, wn, fn): the ziggurat's tables (uint32 and float64, 128 each), given once by noise/streams.py
 *   at import (`_kernel`) before any `add`; the numbers' tests above pin them.
 * - gather(table, index, out, start, stop) / scatter(table, index, values, start, stop): numpy's
 *   take / put with mode="clip" of a float64 table at int64 positions, for i in [start, stop). Called by
 *   compiled.py (`take`, `put`): a batch's copies between its recording and its history and its read's gather
 *   (batch/updater.py); pinned by tests/runtime/test_compiled.py::test_take_and_put_are_numpys_with_clip.
 * - read(program, index): a feature bank's whole read on its work buffer, one call: `program` (bytes) holds
 *   records of READ_SLOTS int64s, an op code and its operands (raw addresses of float64 / int64 arrays that
 *   runtime/read_kernel.py encodes and keeps alive, counts); `index` (int64): the history positions gathered.
 *   Called by runtime/bank.py (`FeatureBank.read`) and runtime/planned.py (`DrawnBank.read`; a read early in an
 *   episode runs the program in two calls, writing padding between them) through runtime/read_kernel.py
 *   (`kernel_read`); pinned by tests/runtime/test_read_kernel.py (each op on signed zeros,
 *   infinities and ties; whole Updaters with and without it) and
 *   tests/noise/test_streams.py::test_the_read_kernel_refuses_an_index_of_another_length.
 * - snapshot(program, keep, step): a bank's snapshot at a physics step: `program` (bytes, 7 int64s: addresses
 *   and counts that runtime/read_kernel.py encodes) says where the state, its positions and the history
 *   lie; row step % rows of the history takes the state at the positions (numpy's take, mode="clip"),
 *   where the row is marked as sampled (the mark then cleared) or, without marks, always; `keep` holds the
 *   arrays the addresses point to. Called by runtime/bank.py (`FeatureBank`) and runtime/planned.py
 *   (`DrawnBank`) through runtime/read_kernel.py (`kernel_snapshot`), at every sampled step; pinned by
 *   tests/runtime/test_read_kernel.py::test_the_compiled_snapshot_is_the_numpy_snapshot.
 * - simd(name): which Philox `add` runs: "fastest" (chosen at import from the CPU: the AVX-512 or AVX2
 *   intrinsics where GCC on x86-64 built them, else the loop the compiler vectorises), "avx512f", "avx2"
 *   (ValueError where the CPU lacks it) or "portable"; returns the name of the one in use. Called by
 *   compiled.py at import (`PHILOX`, which `sensorcfg --version` shows), and by the tests and
 *   benchmarks/noise_kernel.py to run each; pinned by
 *   tests/noise/test_streams.py::test_the_compiled_kernel_gives_the_numpy_numbers_bit_for_bit (each Philox
 *   the CPU runs, against numpy).
 *
 * The noise numbers, bit-identical to the numpy reference in streams.py: Philox4x32-10 on the counters
 * (sample, tag | q, lo32(k1), hi32(k1)) with key (lo32(k0), hi32(k0)); uniforms w 2^-32; normals by
 * Marsaglia and Tsang's ziggurat on each 32-bit word, a rejected word going on with words of its own
 * (lane 3, the key's second word xor (1 + word + 16 a) at attempt a), exactly as streams._fallback does.
 * exp and log are the C library's, which the reference also calls (through Python's math module).
 *
 * Built by setup.py as an optional extension: without a C compiler the package installs without it. No
 * numpy C API: arrays arrive through the buffer protocol. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
/* numpy's roundings: a * b + c is two of them, never one fused multiply-add, whatever flags build this file
 * (setup.py also passes -ffp-contract=off) */
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
#include <math.h>
#include <stdint.h>
#include <string.h>

#define ROUNDS 10
#define BLOCK 64 /* counters per vectorised Philox block */

static uint32_t KN[128];
static double WN[128], FN[128];
static const double R = 3.442620;
static const double TWO_M32 = 2.3283064365386963e-10; /* 2^-32 */

static int set_tables(PyObject *kn, PyObject *wn, PyObject *fn) {
    Py_buffer b[3];
    PyObject *src[3] = {kn, wn, fn};
    void *dst[3] = {KN, WN, FN};
    size_t bytes[3] = {sizeof(KN), sizeof(WN), sizeof(FN)};
    for (int i = 0; i < 3; i++) {
        if (PyObject_GetBuffer(src[i], &b[i], PyBUF_C_CONTIGUOUS) < 0) return -1;
        if ((size_t)b[i].len != bytes[i]) {
            PyBuffer_Release(&b[i]);
            PyErr_SetString(PyExc_ValueError, "ziggurat tables of the wrong size");
            return -1;
        }
        memcpy(dst[i], b[i].buf, bytes[i]);
        PyBuffer_Release(&b[i]);
    }
    return 0;
}

/* one counter's Philox, inlined into the ziggurat's fallback (philox_block, called through its pointer and
 * set up for a block, costs too much for the one counter each rejected word needs); the same rounds as
 * philox_block */
static inline void philox1(uint32_t x[4], uint32_t k0, uint32_t k1) {
    for (int r = 0; r < ROUNDS; r++) {
        if (r) {
            k0 += 0x9E3779B9u;
            k1 += 0xBB67AE85u;
        }
        uint64_t p0 = (uint64_t)x[0] * 0xD2511F53u, p1 = (uint64_t)x[2] * 0xCD9E8D57u;
        uint32_t n0 = (uint32_t)(p1 >> 32) ^ x[1] ^ k0, n2 = (uint32_t)(p0 >> 32) ^ x[3] ^ k1;
        x[0] = n0;
        x[1] = (uint32_t)p1;
        x[2] = n2;
        x[3] = (uint32_t)p0;
    }
}

/* Philox of n <= BLOCK counters (x: four word arrays, k: two key arrays, both overwritten), vectorised
 * across them by the compiler; the words counter after counter into w (w[4 i + v]: word v of counter i) */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
static void philox_portable(int n, uint32_t *restrict x0, uint32_t *restrict x1, uint32_t *restrict x2,
                            uint32_t *restrict x3, uint32_t *restrict k0, uint32_t *restrict k1, uint32_t *restrict w) {
    for (int r = 0; r < ROUNDS; r++) {
        for (int i = 0; i < n; i++) {
            uint64_t p0 = (uint64_t)x0[i] * 0xD2511F53u, p1 = (uint64_t)x2[i] * 0xCD9E8D57u;
            uint32_t n0 = (uint32_t)(p1 >> 32) ^ x1[i] ^ k0[i], n2 = (uint32_t)(p0 >> 32) ^ x3[i] ^ k1[i];
            x0[i] = n0;
            x1[i] = (uint32_t)p1;
            x2[i] = n2;
            x3[i] = (uint32_t)p0;
            k0[i] += 0x9E3779B9u;
            k1[i] += 0xBB67AE85u;
        }
    }
    for (int i = 0; i < n; i++) {
        w[4 * i] = x0[i];
        w[4 * i + 1] = x1[i];
        w[4 * i + 2] = x2[i];
        w[4 * i + 3] = x3[i];
    }
}

typedef void (*PhiloxFn)(int, uint32_t *restrict, uint32_t *restrict, uint32_t *restrict, uint32_t *restrict,
                         uint32_t *restrict, uint32_t *restrict, uint32_t *restrict);

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#include <immintrin.h>
#define SIMD_PHILOX 1
/* The same rounds with intrinsics: the compiler widens each 32-bit product to a full 64-bit one (three
 * multiplies); here one multiply of the even and one of the odd lanes gives both halves, and four vectors of
 * counters are in flight at once so that a product's latency is hidden.
 * Lanes past n compute on zeros and are not stored past w[4 * round-up(n, lanes)] (w holds 4 * BLOCK). */
#define PHILOX_VECTORS(V, SUFFIX, LOAD, MUL, BLEND, XOR3, SET32, SET64, ADD, SRL, SLL)                         \
    const V M0 = SET64(0xD2511F53u), M1 = SET64(0xCD9E8D57u), W0 = SET32((int)0x9E3779B9u),                   \
            W1 = SET32((int)0xBB67AE85u);                                                                      \
    for (int i = 0; i < n; i += 4 * LANES) {                                                                   \
        V a0[4], a1[4], a2[4], a3[4], c0[4], c1[4];                                                            \
        for (int v = 0; v < 4; v++) {                                                                          \
            int at = i + LANES * v, left = n - at;                                                             \
            a0[v] = LOAD(x0 + at, left), a1[v] = LOAD(x1 + at, left), a2[v] = LOAD(x2 + at, left);             \
            a3[v] = LOAD(x3 + at, left), c0[v] = LOAD(k0 + at, left), c1[v] = LOAD(k1 + at, left);             \
        }                                                                                                      \
        for (int r = 0; r < ROUNDS; r++) {                                                                     \
            for (int v = 0; v < 4; v++) {                                                                      \
                V e0 = MUL(a0[v], M0), o0 = MUL(SRL(a0[v], 32), M0);                                           \
                V e1 = MUL(a2[v], M1), o1 = MUL(SRL(a2[v], 32), M1);                                           \
                V lo0 = BLEND(e0, SLL(o0, 32)), hi0 = BLEND(SRL(e0, 32), o0);                                  \
                V lo1 = BLEND(e1, SLL(o1, 32)), hi1 = BLEND(SRL(e1, 32), o1);                                  \
                a0[v] = XOR3(hi1, a1[v], c0[v]);                                                               \
                a2[v] = XOR3(hi0, a3[v], c1[v]);                                                               \
                a1[v] = lo1;                                                                                   \
                a3[v] = lo0;                                                                                   \
                c0[v] = ADD(c0[v], W0);                                                                        \
                c1[v] = ADD(c1[v], W1);                                                                        \
            }                                                                                                  \
        }                                                                                                      \
        for (int v = 0; v < 4 && i + LANES * v < n; v++) interleave##SUFFIX(a0[v], a1[v], a2[v], a3[v], w + 4 * (i + LANES * v)); \
    }

/* four vectors of words (counters in lanes) stored counter after counter, four words each */
__attribute__((target("avx512f"))) static inline void interleave512(__m512i a0, __m512i a1, __m512i a2, __m512i a3,
                                                                    uint32_t *w) {
    __m512i t0 = _mm512_unpacklo_epi32(a0, a1), t1 = _mm512_unpackhi_epi32(a0, a1);
    __m512i t2 = _mm512_unpacklo_epi32(a2, a3), t3 = _mm512_unpackhi_epi32(a2, a3);
    /* per 128-bit lane: u0 counter 0, u1 counter 1, u2 counter 2, u3 counter 3 (of counters 4l .. 4l + 3) */
    __m512i u0 = _mm512_unpacklo_epi64(t0, t2), u1 = _mm512_unpackhi_epi64(t0, t2);
    __m512i u2 = _mm512_unpacklo_epi64(t1, t3), u3 = _mm512_unpackhi_epi64(t1, t3);
    __m512i v0 = _mm512_shuffle_i32x4(u0, u1, 0x44), v1 = _mm512_shuffle_i32x4(u2, u3, 0x44);
    __m512i v2 = _mm512_shuffle_i32x4(u0, u1, 0xEE), v3 = _mm512_shuffle_i32x4(u2, u3, 0xEE);
    _mm512_storeu_si512(w, _mm512_shuffle_i32x4(v0, v1, 0x88));
    _mm512_storeu_si512(w + 16, _mm512_shuffle_i32x4(v0, v1, 0xDD));
    _mm512_storeu_si512(w + 32, _mm512_shuffle_i32x4(v2, v3, 0x88));
    _mm512_storeu_si512(w + 48, _mm512_shuffle_i32x4(v2, v3, 0xDD));
}

__attribute__((target("avx2"))) static inline void interleave256(__m256i a0, __m256i a1, __m256i a2, __m256i a3,
                                                                 uint32_t *w) {
    __m256i t0 = _mm256_unpacklo_epi32(a0, a1), t1 = _mm256_unpackhi_epi32(a0, a1);
    __m256i t2 = _mm256_unpacklo_epi32(a2, a3), t3 = _mm256_unpackhi_epi32(a2, a3);
    __m256i u0 = _mm256_unpacklo_epi64(t0, t2), u1 = _mm256_unpackhi_epi64(t0, t2);
    __m256i u2 = _mm256_unpacklo_epi64(t1, t3), u3 = _mm256_unpackhi_epi64(t1, t3);
    _mm256_storeu_si256((__m256i *)w, _mm256_permute2x128_si256(u0, u1, 0x20));
    _mm256_storeu_si256((__m256i *)(w + 8), _mm256_permute2x128_si256(u2, u3, 0x20));
    _mm256_storeu_si256((__m256i *)(w + 16), _mm256_permute2x128_si256(u0, u1, 0x31));
    _mm256_storeu_si256((__m256i *)(w + 24), _mm256_permute2x128_si256(u2, u3, 0x31));
}

#define LOAD512(p, left) _mm512_maskz_loadu_epi32((__mmask16)((left) >= 16 ? 0xFFFF : (left) > 0 ? (1u << (left)) - 1 : 0), (p))
#define BLEND512(a, b) _mm512_mask_blend_epi32((__mmask16)0xAAAA, (a), (b))
#define XOR512(a, b, c) _mm512_ternarylogic_epi32((a), (b), (c), 0x96)
__attribute__((target("avx512f"))) static void philox_avx512(int n, uint32_t *restrict x0, uint32_t *restrict x1,
                                                             uint32_t *restrict x2, uint32_t *restrict x3,
                                                             uint32_t *restrict k0, uint32_t *restrict k1,
                                                             uint32_t *restrict w) {
    enum { LANES = 16 };
    PHILOX_VECTORS(__m512i, 512, LOAD512, _mm512_mul_epu32, BLEND512, XOR512, _mm512_set1_epi32, _mm512_set1_epi64,
                   _mm512_add_epi32, _mm512_srli_epi64, _mm512_slli_epi64)
}

__attribute__((target("avx2"))) static inline __m256i load256(const uint32_t *p, int left) {
    static const int32_t ones[16] = {-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0};
    int skip = left >= 8 ? 0 : left > 0 ? 8 - left : 8;
    return _mm256_maskload_epi32((const int *)p, _mm256_loadu_si256((const __m256i *)(ones + skip)));
}
#define BLEND256(a, b) _mm256_blend_epi32((a), (b), 0xAA)
#define XOR256(a, b, c) _mm256_xor_si256(_mm256_xor_si256((a), (b)), (c))
__attribute__((target("avx2"))) static void philox_avx2(int n, uint32_t *restrict x0, uint32_t *restrict x1,
                                                        uint32_t *restrict x2, uint32_t *restrict x3,
                                                        uint32_t *restrict k0, uint32_t *restrict k1,
                                                        uint32_t *restrict w) {
    enum { LANES = 8 };
    PHILOX_VECTORS(__m256i, 256, load256, _mm256_mul_epu32, BLEND256, XOR256, _mm256_set1_epi32, _mm256_set1_epi64x,
                   _mm256_add_epi32, _mm256_srli_epi64, _mm256_slli_epi64)
}

/* the fastest the CPU runs (`simd` can switch back to the portable loop, for the tests) */
static PhiloxFn fastest_philox(void) {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return philox_avx512;
    if (__builtin_cpu_supports("avx2")) return philox_avx2;
    return philox_portable;
}
#else
static PhiloxFn fastest_philox(void) { return philox_portable; }
#endif

static PhiloxFn philox_block = philox_portable; /* set at import (PyInit__kernel) */

static inline uint32_t abs32(int32_t v) { return v < 0 ? 0u - (uint32_t)v : (uint32_t)v; }

/* the ziggurat's first try on n words: hz WN[iz] for each, and which it rejects (1 in `rejected`) */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
static void to_normals(int n, const uint32_t *restrict w, double *restrict out, uint8_t *restrict rejected) {
    for (int j = 0; j < n; j++) out[j] = (double)(int32_t)w[j] * WN[w[j] & 127u];
    for (int j = 0; j < n; j++) rejected[j] = abs32((int32_t)w[j]) >= KN[w[j] & 127u];
}

/* streams._fallback for one rejected word hz, word `word` of counter (c0, c1, c2, c3) under key (k0, k1) */
static double fallback(int64_t hz, uint32_t word, const uint32_t c[4], uint32_t k0, uint32_t k1) {
    for (uint32_t a = 0;; a++) {
        uint32_t w[4] = {c[0], c[1] | (3u << 22), c[2], c[3]};
        philox1(w, k0, k1 ^ (1u + word + 16u * a));
        double u0 = ((double)w[0] + 0.5) * TWO_M32, u2 = ((double)w[2] + 0.5) * TWO_M32,
               u3 = ((double)w[3] + 0.5) * TWO_M32;
        int iz = (int)(hz & 127);
        double value = (double)hz * WN[iz];
        if (iz == 0) {
            double t = -log(u2) / R;
            value = hz > 0 ? R + t : -R - t;
            if (-2.0 * log(u3) >= t * t) return value;
            continue;
        }
        if (FN[iz] + u0 * (FN[iz - 1] - FN[iz]) < exp(-0.5 * value * value)) return value;
        int64_t nh = (int32_t)w[1];
        int niz = (int)(nh & 127);
        value = (double)nh * WN[niz];
        if ((nh < 0 ? -nh : nh) < (int64_t)KN[niz]) return value;
        hz = nh;
    }
}

/* One lane of a job: its counters' tag, normals or uniforms, and the optional per-value scale and offset. */
typedef struct {
    uint32_t tag;
    int normal;
    const double *scale, *offset;
    Py_buffer sc, of;
} Lane;

/* A block: n <= BLOCK counters, counter i of sample row_of[i] (its counter index at_of[i]); and its
 * segments: runs of one sample's values, value t0 .. t0 + len of sample `row` at position j of the block. */
typedef struct {
    int n, nseg;
    Py_ssize_t row_of[BLOCK], at_of[BLOCK];
    Py_ssize_t seg_row[BLOCK], seg_t0[BLOCK], seg_j[BLOCK], seg_len[BLOCK];
} Block;

/* The next flag set of eight (0 or 1 each, `any` read from them as one word), cleared from `any`: on a
 * little-endian GNU compiler without a branch per flag, elsewhere flag by flag (clearing it). */
static inline int next_flag(uint64_t *any, uint8_t *flags) {
#if defined(__GNUC__) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    int b = __builtin_ctzll(*any) >> 3;
    *any &= *any - 1;
    (void)flags;
#else
    int b = 0;
    while (!flags[b]) b++;
    flags[b] = 0;
    memcpy(any, flags, sizeof *any);
#endif
    return b;
}

/* The numbers of one lane for a block, before its scale and offset (value v of counter i at val[4 i + v]). */
static void lane_block(const Lane *lane, const Block *b, const uint64_t *k, const int64_t *s, double *val) {
    uint32_t x[4][BLOCK], kk[2][BLOCK], w[4 * BLOCK];
    uint8_t rejected[4 * BLOCK];
    int n = b->n;
    for (int i = 0; i < n; i++) {
        Py_ssize_t r = b->row_of[i];
        x[0][i] = (uint32_t)(uint64_t)s[r];
        x[1][i] = lane->tag | (uint32_t)b->at_of[i];
        x[2][i] = (uint32_t)k[2 * r + 1];
        x[3][i] = (uint32_t)(k[2 * r + 1] >> 32);
        kk[0][i] = (uint32_t)k[2 * r];
        kk[1][i] = (uint32_t)(k[2 * r] >> 32);
    }
    philox_block(n, x[0], x[1], x[2], x[3], kk[0], kk[1], w);
    if (!lane->normal) {
        for (int j = 0; j < 4 * n; j++) val[j] = (double)w[j] * TWO_M32;
        return;
    }
    to_normals(4 * n, w, val, rejected);
    memset(rejected + 4 * n, 0, (size_t)(-4 * n & 7)); /* whole words of eight flags */
    for (int j8 = 0; j8 < 4 * n; j8 += 8) { /* about 1 word in 36 is rejected: eight flags at once */
        uint64_t any;
        memcpy(&any, rejected + j8, sizeof any);
        while (any) {
            int j = j8 + next_flag(&any, rejected + j8);
            int i = j / 4;
            Py_ssize_t r = b->row_of[i];
            uint32_t c[4] = {(uint32_t)(uint64_t)s[r], lane->tag | (uint32_t)b->at_of[i], (uint32_t)k[2 * r + 1],
                             (uint32_t)(k[2 * r + 1] >> 32)};
            val[j] = fallback((int32_t)w[j], (uint32_t)(j & 3), c, (uint32_t)k[2 * r], (uint32_t)(k[2 * r] >> 32));
        }
    }
}

/* A block's lanes into out: per value, each lane's number x scale (rounded), + offset (rounded), summed lane
 * after lane (numpy's total = t0; total += t1 ...), then written or added (out = out + total). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
static void combine(const Lane *lanes, int nl, double (*val)[4 * BLOCK], const Block *b, double *o, const int64_t *rows,
                    Py_ssize_t stride, Py_ssize_t lo, int accumulate) {
    double total[4 * BLOCK];
    for (int g = 0; g < b->nseg; g++) {
        Py_ssize_t t0 = b->seg_t0[g], len = b->seg_len[g];
        double *tot = total + b->seg_j[g];
        for (int l = 0; l < nl; l++) {
            const double *v = val[l] + b->seg_j[g], *sc = lanes[l].scale ? lanes[l].scale + t0 : NULL,
                         *of = lanes[l].offset ? lanes[l].offset + t0 : NULL;
            for (Py_ssize_t t = 0; t < len; t++) {
                double x = sc ? v[t] * sc[t] : v[t];
                if (of) x = x + of[t];
                tot[t] = l ? tot[t] + x : x;
            }
        }
        double *dst = o + (rows ? rows[b->seg_row[g]] : b->seg_row[g]) * stride + lo + t0;
        if (accumulate)
            for (Py_ssize_t t = 0; t < len; t++) dst[t] = dst[t] + tot[t];
        else
            memcpy(dst, tot, sizeof(double) * len);
    }
}

static int get_lanes(PyObject *seq, Py_ssize_t size, Lane *lanes, int *count) {
    /* lanes: a sequence of (tag, normal, scale or None, offset or None), at most 8 */
    PyObject *fast = PySequence_Fast(seq, "lanes must be a sequence");
    if (!fast) return -1;
    Py_ssize_t nl = PySequence_Fast_GET_SIZE(fast);
    if (nl < 1 || nl > 8) {
        Py_DECREF(fast);
        PyErr_SetString(PyExc_ValueError, "add: 1 to 8 lanes");
        return -1;
    }
    *count = 0;
    for (Py_ssize_t l = 0; l < nl; l++) {
        Lane *lane = &lanes[l];
        PyObject *sc = Py_None, *of = Py_None;
        unsigned long tag;
        memset(lane, 0, sizeof(*lane));
        if (!PyArg_ParseTuple(PySequence_Fast_GET_ITEM(fast, l), "kpOO", &tag, &lane->normal, &sc, &of)) break;
        lane->tag = (uint32_t)tag;
        *count = (int)l + 1;
        PyObject *objs[2] = {sc, of};
        Py_buffer *bufs[2] = {&lane->sc, &lane->of};
        const double **ptrs[2] = {&lane->scale, &lane->offset};
        for (int b = 0; b < 2; b++) {
            if (objs[b] == Py_None) continue;
            if (PyObject_GetBuffer(objs[b], bufs[b], PyBUF_C_CONTIGUOUS) < 0) goto fail;
            *ptrs[b] = (const double *)bufs[b]->buf;
            if (bufs[b]->len != (Py_ssize_t)sizeof(double) * size) {
                PyErr_SetString(PyExc_ValueError, "add: a scale or offset is not (size,) float64");
                goto fail;
            }
        }
    }
    Py_DECREF(fast);
    return PyErr_Occurred() ? -1 : 0;
fail:
    Py_DECREF(fast);
    return -1;
}

static void release_lanes(Lane *lanes, int count) {
    for (int l = 0; l < count; l++) {
        if (lanes[l].sc.obj) PyBuffer_Release(&lanes[l].sc);
        if (lanes[l].of.obj) PyBuffer_Release(&lanes[l].of);
    }
}

/* add(keys (m, 2) uint64, samples (m,) int64, size, lanes, out (rows, width) float64, lo, rows (m,) int64
 * or None, accumulate): per sample r the total of its lanes' numbers (x scale, + offset), lane after lane
 * (the first written, the others added: numpy's total = t0; total += t1 ...), then written to, or added to
 * (accumulate: out = out + total), out[rows[r] (r when None), lo:lo + size].
 * width 0: out is flat and rows[r] is where sample r's values start (out[rows[r] + lo:rows[r] + lo + size]). */
static PyObject *add(PyObject *self, PyObject *args) {
    Py_buffer keys, samples, out, rows_buf = {0};
    Py_ssize_t size, width, lo;
    int accumulate, nl = 0;
    PyObject *lanes_obj, *rows_obj, *result = NULL;
    Lane lanes[8];
    if (!PyArg_ParseTuple(args, "y*y*nOw*nnOp", &keys, &samples, &size, &lanes_obj, &out, &width, &lo, &rows_obj,
                          &accumulate))
        return NULL;
    int flat = width == 0;
    Py_ssize_t m = samples.len / 8, nrows = out.len / (Py_ssize_t)sizeof(double) / (width > 0 ? width : 1);
    Py_ssize_t stride = flat ? 1 : width; /* doubles between rows */
    const int64_t *rows = NULL;
    if (get_lanes(lanes_obj, size, lanes, &nl) < 0) goto done;
    if (rows_obj != Py_None) {
        if (PyObject_GetBuffer(rows_obj, &rows_buf, PyBUF_C_CONTIGUOUS) < 0) goto done;
        rows = (const int64_t *)rows_buf.buf;
    }
    /* bounds compared without sums that could overflow: lo + size <= width (2-D), rows[r] + lo + size <= n (flat) */
    int bad = keys.len != 16 * m || size < 0 || width < 0 || lo < 0 || (!flat && (lo > width || size > width - lo)) ||
              (flat && (lo > nrows || size > nrows - lo)) ||
              (!flat && out.len != (Py_ssize_t)sizeof(double) * nrows * width) || (rows && rows_buf.len != 8 * m) ||
              (!rows && (flat || m > nrows));
    for (Py_ssize_t r = 0; rows && !bad && r < m; r++)
        bad = rows[r] < 0 || (flat ? rows[r] > nrows - lo - size : rows[r] >= nrows);
    if (bad) {
        PyErr_SetString(PyExc_ValueError, "add: keys (m, 2), samples (m,), rows (m,) and out (rows, width) disagree");
        goto done;
    }
    const uint64_t *k = (const uint64_t *)keys.buf;
    const int64_t *s = (const int64_t *)samples.buf;
    double *o = (double *)out.buf;
    Py_ssize_t q = (size + 3) / 4;
    Py_BEGIN_ALLOW_THREADS
    double val[8][4 * BLOCK];
    Block blk;
    Py_ssize_t r = 0, at = 0; /* the next counter: sample r, index at */
    while (r < m && q) {
        int n = 0;
        blk.nseg = 0;
        while (n < BLOCK && r < m) { /* the rest of sample r's counters, as many as fit */
            Py_ssize_t take = q - at < BLOCK - n ? q - at : BLOCK - n, t0 = 4 * at;
            Py_ssize_t end = 4 * (at + take) < size ? 4 * (at + take) : size;
            blk.seg_row[blk.nseg] = r;
            blk.seg_t0[blk.nseg] = t0;
            blk.seg_j[blk.nseg] = 4 * n;
            blk.seg_len[blk.nseg++] = end - t0;
            for (Py_ssize_t c = 0; c < take; c++, n++) {
                blk.row_of[n] = r;
                blk.at_of[n] = at + c;
            }
            at += take;
            if (at == q) {
                at = 0;
                r++;
            }
        }
        blk.n = n;
        for (int l = 0; l < nl; l++) lane_block(&lanes[l], &blk, k, s, val[l]);
        combine(lanes, nl, val, &blk, o, rows, stride, lo, accumulate);
    }
    Py_END_ALLOW_THREADS
    result = Py_None;
    Py_INCREF(result);
done:
    release_lanes(lanes, nl);
    if (rows_buf.obj) PyBuffer_Release(&rows_buf);
    PyBuffer_Release(&keys);
    PyBuffer_Release(&samples);
    PyBuffer_Release(&out);
    return result;
}

/* gather(table float64, index int64, out float64, start, stop): out[i] = table[clip(index[i])] for i in
 * [start, stop); scatter(table, index, values, start, stop): table[clip(index[i])] = values[i]. Clip: an
 * index outside the table takes the nearest end, as numpy's mode="clip".
 * A batch gathers right after a rollout has filled the caches with other memory, from positions spread over
 * tens of MB: each value's line is asked for AHEAD positions early, so that the loads overlap instead of
 * waiting one by one (`benchmarks/batch_gather.py` times it). */
#define AHEAD 128
#if defined(__GNUC__) || defined(__clang__)
#define PREFETCH(p) __builtin_prefetch((p), 0, 0)
#else
#define PREFETCH(p) ((void)0)
#endif
static inline int64_t clip_index(int64_t i, int64_t n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

static PyObject *copy(PyObject *args, int scatter) {
    Py_buffer table, index, other;
    Py_ssize_t start, stop;
    if (!PyArg_ParseTuple(args, "w*y*w*nn", &table, &index, &other, &start, &stop)) return NULL;
    Py_ssize_t n = table.len / 8, m = index.len / 8;
    PyObject *result = NULL;
    if (other.len != index.len || start < 0 || stop > m || start > stop || n < 1) {
        PyErr_SetString(PyExc_ValueError, "gather/scatter: table, index and values disagree");
        goto done;
    }
    double *t = (double *)table.buf, *o = (double *)other.buf;
    const int64_t *ix = (const int64_t *)index.buf;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t i = start; i < stop; i++) {
        if (i + AHEAD < stop) PREFETCH(t + clip_index(ix[i + AHEAD], n));
        int64_t at = clip_index(ix[i], n);
        if (scatter)
            t[at] = o[i];
        else
            o[i] = t[at];
    }
    Py_END_ALLOW_THREADS
    result = Py_None;
    Py_INCREF(result);
done:
    PyBuffer_Release(&table);
    PyBuffer_Release(&index);
    PyBuffer_Release(&other);
    return result;
}

static PyObject *gather(PyObject *self, PyObject *args) { return copy(args, 0); }
static PyObject *scatter(PyObject *self, PyObject *args) { return copy(args, 1); }

static PyObject *tables(PyObject *self, PyObject *args) {
    PyObject *kn, *wn, *fn;
    if (!PyArg_ParseTuple(args, "OOO", &kn, &wn, &fn)) return NULL;
    if (set_tables(kn, wn, fn) < 0) return NULL;
    Py_RETURN_NONE;
}

/* read(program int64, index int64): a feature bank's compiled read (sensorcfg/runtime/read_kernel.py encodes
 * it; the numpy steps of runtime/bank_read.py and runtime/bank_noise.py are the reference, compared bit for bit
 * by tests/runtime/test_read_kernel.py). `program` holds records of READ_SLOTS int64s: an op code and its operands,
 * raw addresses of float64 / int64 arrays the encoder keeps alive, counts. `index`: the history positions
 * the read gathers (n of them). Each op is numpy's elementwise arithmetic in numpy's order, so the bits are
 * numpy's: maximum and minimum keep the second operand on ties and the first NaN, as numpy's loops do;
 * reductions run along the buffer axis row by row, sums from +0.0 (numpy's add.reduce over axis 0). */
#define READ_SLOTS 6
enum { R_GATHER = 1, R_TERM, R_ADD, R_MUL, R_QUANTIZE, R_CLIP, R_TAKE, R_SUM, R_MAX, R_MIN, R_DIVIDE };

static inline double np_maximum(double a, double b) { return (a > b || isnan(a)) ? a : b; }
static inline double np_minimum(double a, double b) { return (a < b || isnan(a)) ? a : b; }

static void read_op(const int64_t *op, const int64_t *ix, Py_ssize_t n) {
    double *g = (double *)(intptr_t)op[1];
    const double *a = (const double *)(intptr_t)op[2], *b = (const double *)(intptr_t)op[3];
    const int64_t *pos = (const int64_t *)(intptr_t)op[4];
    int64_t count = op[5];
    switch (op[0]) {
    case R_GATHER: /* g[i] = a[clip(ix[i])], a of op[3] values, g of count (the index's length, checked) */
        for (Py_ssize_t i = 0; i < n; i++) g[i] = a[clip_index(ix[i], op[3])];
        break;
    case R_TERM: /* a noise field a (op[3] values) at the gathered positions, added at pos */
        for (int64_t k = 0; k < count; k++) g[pos[k]] = g[pos[k]] + a[clip_index(ix[pos[k]], op[3])];
        break;
    case R_ADD: /* this episode's draws a at columns b (int64) */
        for (int64_t k = 0; k < count; k++) g[pos[k]] = g[pos[k]] + a[((const int64_t *)b)[k]];
        break;
    case R_MUL:
        for (int64_t k = 0; k < count; k++) g[pos[k]] = g[pos[k]] * a[((const int64_t *)b)[k]];
        break;
    case R_QUANTIZE: /* divide, rint, multiply: arithmetic.quantize */
        for (int64_t k = 0; k < count; k++) g[pos[k]] = rint(g[pos[k]] / a[k]) * a[k];
        break;
    case R_CLIP: /* maximum with a, then minimum with b: arithmetic.clip */
        for (int64_t k = 0; k < count; k++) g[pos[k]] = np_minimum(np_maximum(g[pos[k]], a[k]), b[k]);
        break;
    case R_TAKE: /* g[k] = a[pos[k]]: the families' blocks stacked from the gathered windows and pads */
        for (int64_t k = 0; k < count; k++) g[k] = a[pos[k]];
        break;
    case R_SUM: case R_MAX: case R_MIN: { /* out g (width op[5]) from the block a (op[4] rows) */
        int64_t rows = op[4], width = count;
        for (int64_t j = 0; j < width; j++) g[j] = op[0] == R_SUM ? 0.0 + a[j] : a[j];
        for (int64_t r = 1; r < rows; r++) {
            const double *row = a + r * width;
            if (op[0] == R_SUM)
                for (int64_t j = 0; j < width; j++) g[j] = g[j] + row[j];
            else if (op[0] == R_MAX)
                for (int64_t j = 0; j < width; j++) g[j] = np_maximum(g[j], row[j]);
            else
                for (int64_t j = 0; j < width; j++) g[j] = np_minimum(g[j], row[j]);
        }
        break;
    }
    case R_DIVIDE: /* the means: g / a */
        for (int64_t k = 0; k < count; k++) g[k] = g[k] / a[k];
        break;
    }
}

static PyObject *read_bank(PyObject *self, PyObject *args) {
    Py_buffer program, index;
    if (!PyArg_ParseTuple(args, "y*y*", &program, &index)) return NULL;
    const int64_t *ops = (const int64_t *)program.buf;
    Py_ssize_t nops = program.len / (8 * READ_SLOTS);
    int bad = program.len % (8 * READ_SLOTS) != 0;
    for (Py_ssize_t o = 0; o < nops && !bad; o++) /* a gather fills its work buffer: the index is that long */
        bad = ops[o * READ_SLOTS] == R_GATHER && ops[o * READ_SLOTS + 5] != index.len / 8;
    if (!bad)
        for (Py_ssize_t o = 0; o < nops; o++) read_op(ops + o * READ_SLOTS, (const int64_t *)index.buf, index.len / 8);
    PyBuffer_Release(&program);
    PyBuffer_Release(&index);
    if (bad) {
        PyErr_SetString(PyExc_ValueError, "read: the index is not as long as the program's work buffer");
        return NULL;
    }
    Py_RETURN_NONE;
}

/* snapshot(program, keep, step): a bank's snapshot at `step` (sensorcfg/runtime/read_kernel.py): program is
 * int64 (need, raw, n, source, width, history, rows), addresses and counts; when need[step % rows] (need 0:
 * always), clear it and copy raw[clip(source[i])] into row step % rows of history for i < width (numpy's
 * take, mode="clip"). `keep` holds the arrays the addresses point to (unused here). */
static PyObject *snapshot(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 3 || !PyBytes_Check(args[0]) || PyBytes_GET_SIZE(args[0]) != 7 * 8) {
        PyErr_SetString(PyExc_TypeError, "snapshot(program, keep, step): program is 7 int64s");
        return NULL;
    }
    const int64_t *p = (const int64_t *)PyBytes_AS_STRING(args[0]);
    long long step = PyLong_AsLongLong(args[2]);
    if (step == -1 && PyErr_Occurred()) return NULL;
    int64_t rows = p[6], n = p[2], width = p[4];
    if (rows < 1 || n < 1 || width < 0) {
        PyErr_SetString(PyExc_ValueError, "snapshot: empty history or state");
        return NULL;
    }
    int64_t row = step % rows;
    if (row < 0) row += rows;
    uint8_t *need = (uint8_t *)(intptr_t)p[0];
    if (!need || need[row]) {
        if (need) need[row] = 0;
        const double *raw = (const double *)(intptr_t)p[1];
        const int64_t *source = (const int64_t *)(intptr_t)p[3];
        double *out = (double *)(intptr_t)p[5] + row * width;
        for (int64_t i = 0; i < width; i++) out[i] = raw[clip_index(source[i], n)];
    }
    Py_RETURN_NONE;
}

/* simd(name): which Philox runs: "fastest" (what the CPU has, as at import), "avx512f", "avx2" (ValueError where
 * the CPU lacks it) or "portable" (the compiler's loop); returns the name of the one now in use. The numbers are
 * the same with each (tests/noise/test_streams.py runs them all). */
static PyObject *simd(PyObject *self, PyObject *args) {
    const char *name;
    if (!PyArg_ParseTuple(args, "s", &name)) return NULL;
#ifdef SIMD_PHILOX
    __builtin_cpu_init();
#endif
    struct { const char *name; PhiloxFn fn; int runs; } known[] = {
#ifdef SIMD_PHILOX
        {"avx512f", philox_avx512, __builtin_cpu_supports("avx512f")}, {"avx2", philox_avx2, __builtin_cpu_supports("avx2")},
#endif
        {"portable", philox_portable, 1}};
    int count = (int)(sizeof(known) / sizeof(known[0]));
    PhiloxFn fn = strcmp(name, "fastest") == 0 ? fastest_philox() : NULL;
    for (int i = 0; i < count && !fn; i++) {
        if (strcmp(name, known[i].name) == 0 && known[i].runs) fn = known[i].fn;
    }
    if (!fn) {
        PyErr_Format(PyExc_ValueError, "simd: %s is not a Philox this CPU runs", name);
        return NULL;
    }
    philox_block = fn; /* a switch for tests and benchmarks: not while other threads run `add` */
    for (int i = 0; i < count; i++)
        if (known[i].fn == fn) return PyUnicode_FromString(known[i].name);
    PyErr_SetString(PyExc_RuntimeError, "simd: unknown Philox");
    return NULL;
}

static PyMethodDef methods[] = {
    {"add", add, METH_VARARGS,
     "add(keys, samples, size, lanes, out, width, lo, rows, accumulate): the lanes' numbers, summed, into out's rows."},
    {"tables", tables, METH_VARARGS, "tables(kn, wn, fn): the ziggurat's tables (from streams.py)."},
    {"gather", gather, METH_VARARGS, "gather(table, index, out, start, stop): out[i] = table[index[i]] (clipped)."},
    {"scatter", scatter, METH_VARARGS, "scatter(table, index, values, start, stop): table[index[i]] = values[i] (clipped)."},
    {"read", read_bank, METH_VARARGS,
     "read(program, index): a feature bank's compiled read on its work buffer (sensorcfg/runtime/read_kernel.py)."},
    {"snapshot", (PyCFunction)(void (*)(void))snapshot, METH_FASTCALL,
     "snapshot(program, keep, step): a bank's snapshot of the state at `step` (sensorcfg/runtime/read_kernel.py)."},
    {"simd", simd, METH_VARARGS, "simd(name): which Philox runs (fastest, avx512f, avx2 or portable); the one in use."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_kernel",
                                    "sensorcfg's optional compiled kernels (see sensorcfg/compiled.py).", -1, methods};

PyMODINIT_FUNC PyInit__kernel(void) {
    philox_block = fastest_philox();
    return PyModule_Create(&module);
}
