// CRC-32 (IEEE 802.3, reflected 0xEDB88320: MCAP's, zlib's) of a buffer, folded with carry-less multiplication
// (PCLMULQDQ) where the processor has it (about 7x zlib's crc32 here; zlib's is a third of reading an MCAP's chunk),
// zlib's crc32 otherwise and for the last bytes.
#include "crc32.hpp"

#include <zlib.h>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define GA_CRC_PCLMUL 1
#endif

namespace gyro_allan {
namespace rosbag2 {
namespace {
#ifdef GA_CRC_PCLMUL
/// Folding per Gopal et al., "Fast CRC Computation for Generic Polynomials Using PCLMULQDQ Instruction" (Intel, 2009):
/// four 128-bit lanes folded 512 bits at a time (x^(4*128+32), x^(4*128-32) mod P), then into one lane (x^(128+32),
/// x^(128-32)), 128 -> 64 bits (x^64 mod P) and a Barrett reduction to 32 bits (P' and mu = x^64 / P). Constants
/// for the reflected polynomial, each shifted left by one bit as reflection requires. `len` >= 64, a multiple of 16;
/// `crc` is the running (not inverted) register.
#define GA_CRC_TARGET __attribute__((target("pclmul,sse4.1")))
GA_CRC_TARGET inline __m128i load(const uint8_t* q) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(q)); }
/// x folded forward by the distance k encodes, added to the next block.
GA_CRC_TARGET inline __m128i fold(__m128i x, __m128i k, __m128i next) {
  return _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x00), _mm_clmulepi64_si128(x, k, 0x11)), next);
}

GA_CRC_TARGET uint32_t foldClmul(uint32_t crc, const uint8_t* p, size_t len) {
  const __m128i k1k2 = _mm_set_epi64x(0x01c6e41596LL, 0x0154442bd4LL);
  const __m128i k3k4 = _mm_set_epi64x(0x00ccaa009eLL, 0x01751997d0LL);
  const __m128i k5 = _mm_set_epi64x(0, 0x0163cd6124LL);
  const __m128i poly = _mm_set_epi64x(0x01f7011641LL, 0x01db710641LL);
  const __m128i mask32 = _mm_setr_epi32(-1, 0, -1, 0);
  __m128i x1 = _mm_xor_si128(load(p), _mm_cvtsi32_si128(static_cast<int>(crc)));
  __m128i x2 = load(p + 16), x3 = load(p + 32), x4 = load(p + 48);
  p += 64;
  len -= 64;
  for (; len >= 64; p += 64, len -= 64) {
    x1 = fold(x1, k1k2, load(p));
    x2 = fold(x2, k1k2, load(p + 16));
    x3 = fold(x3, k1k2, load(p + 32));
    x4 = fold(x4, k1k2, load(p + 48));
  }
  x1 = fold(x1, k3k4, x2);
  x1 = fold(x1, k3k4, x3);
  x1 = fold(x1, k3k4, x4);
  for (; len >= 16; p += 16, len -= 16) x1 = fold(x1, k3k4, load(p));
  // 128 -> 64 bits.
  __m128i t = _mm_clmulepi64_si128(x1, k3k4, 0x10);
  x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), t);
  t = _mm_srli_si128(x1, 4);
  x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, mask32), k5, 0x00), t);
  // Barrett: 64 -> 32 bits.
  t = _mm_clmulepi64_si128(_mm_and_si128(x1, mask32), poly, 0x10);
  t = _mm_clmulepi64_si128(_mm_and_si128(t, mask32), poly, 0x00);
  return static_cast<uint32_t>(_mm_extract_epi32(_mm_xor_si128(x1, t), 1));
}
#endif
}  // namespace

uint32_t crc32Update(uint32_t crc, const uint8_t* p, size_t n) {
#ifdef GA_CRC_PCLMUL
  static const bool clmul = __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1");
  if (clmul && n >= 64) {
    // zlib's running value is the register inverted.
    const size_t body = n & ~static_cast<size_t>(15);
    crc = ~foldClmul(~crc, p, body);
    p += body;
    n -= body;
  }
#endif
  for (; n > 0;) {  // zlib takes uInt lengths
    const uInt k = n > (1u << 30) ? (1u << 30) : static_cast<uInt>(n);
    crc = static_cast<uint32_t>(crc32(crc, p, k));
    p += k;
    n -= k;
  }
  return crc;
}

}  // namespace rosbag2
}  // namespace gyro_allan
