"""Counter-based random numbers on a Warp device: `sensorcfg.noise.streams`'s numbers, as Warp functions.

The same Philox4x32-10 of the same counters and keys as the numpy reference (`streams.philox`,
`streams._counters`): value v of sample j of stage s, lane l, of a sensor's 128-bit episode key (k0, k1) comes
from word v mod 4 of

    counter = (j mod 2^32, s << 24 | l << 22 | v // 4, lo32(k1), hi32(k1)),  key = (lo32(k0), hi32(k0)).

A uniform is word 2^-32 (float64, in [0, 1)); a normal is the word through Marsaglia and Tsang's ziggurat
over `streams._ziggurat_tables()` (passed to the device as a `Ziggurat` of arrays), a word it rejects going on
with words of its own exactly as `streams._fallback` does (attempt a: Philox at the counter with lane 3, the
key's second word xor (1 + word + 16 a)). Integer arithmetic is uint32 (the 32x32 -> 64-bit products in
uint64), so words and uniforms are equal to numpy's bit for bit, as are normals the ziggurat takes on their
first word; the rare wedge and tail values go through the device's exp and log (the C library's on Warp's CPU
device, CUDA's on a GPU, which may differ from the C library's in the last bit).

`philox4x32`, `block`, `uniform`, `normal` and `value` are `@wp.func`s for the engine's own kernels; `numbers`
is one stage's numbers for m samples, as `streams.numbers` gives for a `Draw`. A function is compiled into the
module of the kernel calling it, under that module's options: a module whose kernels call these functions
sets `wp.set_module_options(MODULE_OPTIONS)`, without which the compiler may fuse the ziggurat's wedge test
(f + u (f' - f)) into one FMA, rounding differently from numpy (CUDA does by default).
"""

import numpy as np
import warp as wp

from ..noise import streams

__all__ = ["MODULE_OPTIONS", "Ziggurat", "block", "counter", "normal", "numbers", "philox4x32", "tag", "uniform",
           "value", "ziggurat"]

MODULE_OPTIONS = {"fuse_fp": False, "enable_backward": False}  # numpy's roundings; no adjoints (nothing is
# differentiated), which halves the compile time
wp.set_module_options(MODULE_OPTIONS)

_M0 = wp.constant(wp.uint64(0xD2511F53))  # Philox4x32 multipliers
_M1 = wp.constant(wp.uint64(0xCD9E8D57))
_W0 = wp.constant(wp.uint32(0x9E3779B9))  # its key schedule's increments
_W1 = wp.constant(wp.uint32(0xBB67AE85))
_SHIFT = wp.constant(wp.uint64(32))
_FALLBACK_LANE = wp.constant(wp.uint32(3 << 22))  # the counter's lane bits of the ziggurat's fallback words
_SCALE = wp.constant(wp.float64(2.0 ** -32))  # word -> [0, 1)
_HALF = wp.constant(wp.float64(0.5))
_R = wp.constant(wp.float64(streams._R))  # the start of the ziggurat's tail
_MAX_STAGE, _MAX_LANE, _MAX_SIZE = 256, 3, 1 << 22  # as `streams.numbers` allows


@wp.struct
class Ziggurat:
    """Marsaglia and Tsang's 128-layer tables (`streams._ziggurat_tables`) on a device."""

    kn: wp.array[wp.uint32]
    wn: wp.array[wp.float64]
    fn: wp.array[wp.float64]


_TABLES: dict[str, Ziggurat] = {}


def ziggurat(device: wp.Device | str | None = None) -> Ziggurat:
    """The ziggurat's tables on `device` (made once per device)."""
    dev = wp.get_device(device)
    name = str(dev)
    if name not in _TABLES:
        kn, wn, fn = streams._ziggurat_tables()
        z = Ziggurat()
        z.kn = wp.array(kn, dtype=wp.uint32, device=dev)
        z.wn = wp.array(wn, dtype=wp.float64, device=dev)
        z.fn = wp.array(fn, dtype=wp.float64, device=dev)
        _TABLES[name] = z
    return _TABLES[name]


@wp.func
def philox4x32(c: wp.vec4ui, k: wp.vec2ui) -> wp.vec4ui:
    """Philox4x32-10 of counter c under key k: four 32-bit words."""
    x0, x1, x2, x3 = c[0], c[1], c[2], c[3]
    k0, k1 = k[0], k[1]
    for r in range(10):
        if r > 0:
            k0 = k0 + _W0
            k1 = k1 + _W1
        p0 = wp.uint64(x0) * _M0
        p1 = wp.uint64(x2) * _M1
        y0 = wp.uint32(p1 >> _SHIFT) ^ x1 ^ k0
        y2 = wp.uint32(p0 >> _SHIFT) ^ x3 ^ k1
        x1 = wp.uint32(p1)
        x3 = wp.uint32(p0)
        x0 = y0
        x2 = y2
    return wp.vec4ui(x0, x1, x2, x3)


@wp.func
def counter(sample: wp.int64, tag: wp.uint32, q: wp.int32, k1: wp.uint64) -> wp.vec4ui:
    """The counter of values 4q .. 4q + 3 of sample `sample` under stage/lane `tag` (`tag`), key word k1."""
    return wp.vec4ui(wp.uint32(wp.uint64(sample)), tag | wp.uint32(q), wp.uint32(k1), wp.uint32(k1 >> _SHIFT))


@wp.func
def key(k0: wp.uint64) -> wp.vec2ui:
    """Philox's key from the episode key's first word k0: (lo32, hi32)."""
    return wp.vec2ui(wp.uint32(k0), wp.uint32(k0 >> _SHIFT))


@wp.func
def block(k0: wp.uint64, k1: wp.uint64, sample: wp.int64, tag: wp.uint32, q: wp.int32) -> wp.vec4ui:
    """The four words of values 4q .. 4q + 3 of `sample` under `tag`, episode key (k0, k1)."""
    return philox4x32(counter(sample, tag, q, k1), key(k0))


@wp.func
def uniform(word: wp.uint32) -> wp.float64:
    """A word as a uniform in [0, 1): word 2^-32."""
    return wp.float64(word) * _SCALE


@wp.func
def _open(word: wp.uint32) -> wp.float64:
    """A word as a uniform in (0, 1): (word + 1/2) 2^-32."""
    return (wp.float64(word) + _HALF) * _SCALE


@wp.func
def _fallback(hz0: wp.int32, c: wp.vec4ui, k: wp.vec2ui, word: wp.int32, z: Ziggurat) -> wp.float64:
    """`streams._fallback` of a rejected word hz0 (word `word` of counter c, key k): attempts of four words
    each until one is accepted."""
    fc = wp.vec4ui(c[0], c[1] | _FALLBACK_LANE, c[2], c[3])
    hz = wp.int64(hz0)
    attempt = wp.uint32(0)
    out = wp.float64(0.0)
    done = bool(False)
    while not done:
        tweak = wp.uint32(1) + wp.uint32(word) + wp.uint32(16) * attempt
        w = philox4x32(fc, wp.vec2ui(k[0], k[1] ^ tweak))
        iz = wp.int32(hz & wp.int64(127))
        v = wp.float64(hz) * z.wn[iz]
        if iz == 0:  # the base layer: x from the exponential tail
            t = -wp.log(_open(w[2])) / _R
            if hz > wp.int64(0):
                v = _R + t
            else:
                v = -_R - t
            if wp.float64(-2.0) * wp.log(_open(w[3])) >= t * t:
                out = v
                done = True
        else:
            f = z.fn[iz]
            if f + _open(w[0]) * (z.fn[iz - 1] - f) < wp.exp(wp.float64(-0.5) * v * v):
                out = v
                done = True
            else:  # the next word, accepted at once inside its layer
                nh = wp.int64(wp.int32(w[1]))
                niz = wp.int32(nh & wp.int64(127))
                if wp.abs(nh) < wp.int64(z.kn[niz]):
                    out = wp.float64(nh) * z.wn[niz]
                    done = True
                hz = nh
        attempt = attempt + wp.uint32(1)
    return out


@wp.func
def normal(words: wp.vec4ui, word: wp.int32, c: wp.vec4ui, k: wp.vec2ui, z: Ziggurat) -> wp.float64:
    """The standard normal of word `word` of `words` (Philox of counter c, key k) by the ziggurat."""
    w = words[word]
    hz = wp.int32(w)
    iz = wp.int32(w & wp.uint32(127))
    magnitude = w
    if hz < 0:
        magnitude = wp.uint32(0) - w
    if magnitude < z.kn[iz]:
        return wp.float64(hz) * z.wn[iz]
    return _fallback(hz, c, k, word, z)


@wp.func
def value(k0: wp.uint64, k1: wp.uint64, sample: wp.int64, tag: wp.uint32, v: wp.int32, is_normal: bool,
          z: Ziggurat) -> wp.float64:
    """Value v of `sample` under `tag`: a standard normal or a uniform in [0, 1)."""
    c = counter(sample, tag, v // 4, k1)
    k = key(k0)
    words = philox4x32(c, k)
    if is_normal:
        return normal(words, v % 4, c, k, z)
    return uniform(words[v % 4])


@wp.kernel
def _numbers(
    # In: per draw, its key and sample index; the stage's and lane's `tag`, the values per sample
    keys: wp.array2d[wp.uint64], samples: wp.array[wp.int64], tag: wp.uint32, size: wp.int32, is_normal: bool,
    z: Ziggurat,
    # Out:
    out: wp.array2d[wp.float64],
):
    i, q = wp.tid()
    c = counter(samples[i], tag, q, keys[i, 1])
    k = key(keys[i, 0])
    words = philox4x32(c, k)
    for j in range(4):
        v = 4 * q + j
        if v < size:
            if is_normal:
                out[i, v] = normal(words, j, c, k, z)
            else:
                out[i, v] = uniform(words[j])


def tag(stage: int, lane: int) -> int:
    """A stage's and lane's counter bits, s << 24 | l << 22 (stage < 256, lane < 3: lane 3 is the
    ziggurat's fallback)."""
    if not (0 <= stage < _MAX_STAGE and 0 <= lane < _MAX_LANE):
        raise ValueError(f"a noise stage is < {_MAX_STAGE} and its lane < {_MAX_LANE}; got {stage}, {lane}")
    return stage << 24 | lane << 22


def numbers(keys: np.ndarray | wp.array, samples: np.ndarray | wp.array, stage: int, lane: int, size: int,
            normal: bool, device: wp.Device | str | None = None, out: wp.array | None = None) -> wp.array:
    """The numbers of one draw, (m, size) float64 on `device`: the values `streams.numbers` gives for
    Draw(keys, samples, stage, lane, size, normal). keys (m, 2) uint64 (episode key words k0, k1), samples (m,)
    int64 sample indices (>= 0), as numpy arrays or Warp arrays on `device`; `out` to write into."""
    if not 0 <= size <= _MAX_SIZE:
        raise ValueError(f"a noise stage draws at most {_MAX_SIZE} values per sample; got {size}")
    dev = wp.get_device(device)
    wkeys = keys if isinstance(keys, wp.array) else wp.array(np.ascontiguousarray(keys, np.uint64).reshape(-1, 2),
                                                             dtype=wp.uint64, device=dev)
    wsamples = samples if isinstance(samples, wp.array) else wp.array(
        np.ascontiguousarray(samples, np.int64).ravel(), dtype=wp.int64, device=dev)
    m = wsamples.shape[0]
    if wkeys.shape != (m, 2):
        raise ValueError(f"keys must be (m, 2) for m = {m} samples; got {wkeys.shape}")
    if out is None:
        out = wp.empty((m, size), dtype=wp.float64, device=dev)
    if m and size:
        wp.launch(_numbers, dim=(m, -(-size // 4)), inputs=[wkeys, wsamples, wp.uint32(tag(stage, lane)), size,
                                                              normal, ziggurat(dev)],
                  outputs=[out], device=dev)
    return out
