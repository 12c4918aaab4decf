/* The optional compiled form of sensorcfg.noise.streams.numbers: one draw's numbers, bit-identical to the
 * numpy reference in streams.py (tests/test_streams.py compares the two). Philox4x32-10 on the counters
 * (sample, tag | q, lo32(k1), hi32(k1)) with key (lo32(k0), hi32(k0)); uniforms w 2^-32; normals by
 * Marsaglia and Tsang's ziggurat on each 32-bit word, a rejected word going on with words of its own
 * (lane 3, the key's second word xor (1 + word + 16 a) at attempt a), exactly as streams._fallback does.
 * exp and log are the C library's, which the reference also calls (through Python's math module).
 *
 * Built by setup.py as an optional extension: without a C compiler the package installs without it and
 * streams.py uses numpy. No numpy C API: arrays arrive through the buffer protocol. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
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

/* Philox of n <= BLOCK counters in place (x: four word arrays, k: two key arrays), vectorised across them */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
static void philox_block(int n, uint32_t *restrict x0, uint32_t *restrict x1, uint32_t *restrict x2,
                         uint32_t *restrict x3, uint32_t *restrict k0, uint32_t *restrict k1) {
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
}

static inline uint32_t abs32(int32_t v) { return v < 0 ? 0u - (uint32_t)v : (uint32_t)v; }

/* the ziggurat's first try on 4 BLOCK words: hz WN[iz] for each, and which it rejects */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
static void to_normals(const uint32_t *restrict w, double *restrict out, uint8_t *restrict rejected) {
    for (int j = 0; j < 4 * BLOCK; j++) {
        int32_t hz = (int32_t)w[j];
        uint32_t iz = w[j] & 127u;
        out[j] = (double)hz * WN[iz];
        rejected[j] = abs32(hz) >= KN[iz];
    }
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

/* fill(keys (m, 2) uint64, samples (m,) int64, tag, size, normal, out (m, size) float64[, scale (size,),
 * offset (size,), add]): each number x becomes x scale (when given), then + offset (when given), and is
 * written to out, or added to it (add): the roundings of numpy's z *= scale; z += offset; out += z. */
static PyObject *fill(PyObject *self, PyObject *args) {
    Py_buffer keys, samples, out, sc = {0}, of = {0};
    unsigned long tag;
    Py_ssize_t size;
    int normal, add = 0;
    PyObject *scale_obj = Py_None, *offset_obj = Py_None, *result = NULL;
    if (!PyArg_ParseTuple(args, "y*y*knpw*|OOp", &keys, &samples, &tag, &size, &normal, &out, &scale_obj,
                          &offset_obj, &add))
        return NULL;
    Py_ssize_t m = samples.len / 8;
    const double *scale = NULL, *offset = NULL;
    if (scale_obj != Py_None) {
        if (PyObject_GetBuffer(scale_obj, &sc, PyBUF_C_CONTIGUOUS) < 0) goto done;
        scale = (const double *)sc.buf;
    }
    if (offset_obj != Py_None) {
        if (PyObject_GetBuffer(offset_obj, &of, PyBUF_C_CONTIGUOUS) < 0) goto done;
        offset = (const double *)of.buf;
    }
    if (keys.len != 16 * m || out.len != (Py_ssize_t)sizeof(double) * m * size || size < 0 ||
        (scale && sc.len != (Py_ssize_t)sizeof(double) * size) || (offset && of.len != (Py_ssize_t)sizeof(double) * size)) {
        PyErr_SetString(PyExc_ValueError, "fill: keys (m, 2), samples (m,), out (m, size), scale and offset (size,) disagree");
        goto done;
    }
    const uint64_t *k = (const uint64_t *)keys.buf;
    const int64_t *s = (const int64_t *)samples.buf;
    double *o = (double *)out.buf;
    Py_ssize_t q = (size + 3) / 4;
    Py_BEGIN_ALLOW_THREADS
    /* counter j = r q + i (row r, i < q) in blocks of BLOCK, across rows */
    uint32_t x[4][BLOCK], kk[2][BLOCK], key[2][BLOCK], c1[BLOCK];
    double values[4][BLOCK];
    uint8_t rejected[4 * BLOCK];
    Py_ssize_t total = m * q, row_of[BLOCK], at_of[BLOCK], r = 0, at = 0;
    for (Py_ssize_t j0 = 0; j0 < total; j0 += BLOCK) {
        int n = (int)(total - j0 < BLOCK ? total - j0 : BLOCK);
        for (int i = 0; i < n; i++, at++) {
            if (at == q) {
                at = 0;
                r++;
            }
            row_of[i] = r;
            at_of[i] = at;
            x[0][i] = (uint32_t)(uint64_t)s[r];
            x[1][i] = c1[i] = (uint32_t)tag | (uint32_t)at;
            x[2][i] = (uint32_t)k[2 * r + 1];
            x[3][i] = (uint32_t)(k[2 * r + 1] >> 32);
            key[0][i] = kk[0][i] = (uint32_t)k[2 * r];
            key[1][i] = kk[1][i] = (uint32_t)(k[2 * r] >> 32);
        }
        philox_block(n, x[0], x[1], x[2], x[3], kk[0], kk[1]);
        /* the numbers of the block's 4 n words (vectorised: value v of counter i at j = v BLOCK + i) */
        double *val = &values[0][0];
        if (normal) {
            to_normals(&x[0][0], val, rejected);
            for (int j = 0; j < 4 * BLOCK; j++) {
                int i = j % BLOCK, v = j / BLOCK;
                if (!rejected[j] || i >= n) continue;
                Py_ssize_t ri = row_of[i];
                uint32_t cc[4] = {(uint32_t)(uint64_t)s[ri], c1[i], (uint32_t)k[2 * ri + 1],
                                  (uint32_t)(k[2 * ri + 1] >> 32)};
                val[j] = fallback((int32_t)x[v][i], (uint32_t)v, cc, key[0][i], key[1][i]);
            }
        } else {
            for (int j = 0; j < 4 * BLOCK; j++) val[j] = (double)(&x[0][0])[j] * TWO_M32;
        }
        for (int i = 0; i < n; i++) {
            Py_ssize_t first = 4 * at_of[i];
            int count = size - first < 4 ? (int)(size - first) : 4;
            double *dst = o + row_of[i] * size + first;
            for (int v = 0; v < count; v++) {
                double value = values[v][i];
                if (scale) value = value * scale[first + v];
                if (offset) value = value + offset[first + v];
                dst[v] = add ? dst[v] + value : value;
            }
        }
    }
    Py_END_ALLOW_THREADS
    result = Py_None;
    Py_INCREF(result);
done:
    if (sc.obj) PyBuffer_Release(&sc);
    if (of.obj) PyBuffer_Release(&of);
    PyBuffer_Release(&keys);
    PyBuffer_Release(&samples);
    PyBuffer_Release(&out);
    return result;
}

static PyObject *tables(PyObject *self, PyObject *args) {
    PyObject *kn, *wn, *fn;
    if (!PyArg_ParseTuple(args, "OOO", &kn, &wn, &fn)) return NULL;
    if (set_tables(kn, wn, fn) < 0) return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"fill", fill, METH_VARARGS,
     "fill(keys, samples, tag, size, normal, out[, scale, offset, add]): one draw's numbers into out."},
    {"tables", tables, METH_VARARGS, "tables(kn, wn, fn): the ziggurat's tables (from streams.py)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_philox",
                                    "Compiled counter-based numbers (see sensorcfg/noise/streams.py).", -1, methods};

PyMODINIT_FUNC PyInit__philox(void) { return PyModule_Create(&module); }
