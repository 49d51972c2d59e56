// Shared byte reader for the libFuzzer targets: decodes parameters and sample arrays from the fuzz input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace gyro_allan_fuzz {

class Bytes {
 public:
  Bytes(const uint8_t* data, size_t size) : p_(data), n_(size) {}
  size_t left() const { return n_; }
  uint8_t u8() {
    if (n_ == 0) return 0;
    --n_;
    return *p_++;
  }
  uint16_t u16() { return static_cast<uint16_t>(u8() | (u8() << 8)); }
  int16_t i16() { return static_cast<int16_t>(u16()); }
  /// Raw IEEE double (NaN, Inf, denormals and huge values included) when enough bytes are left, else 0.
  double raw() {
    if (n_ < 8) {
      n_ = 0;
      return 0;
    }
    double v;
    std::memcpy(&v, p_, 8);
    p_ += 8;
    n_ -= 8;
    return v;
  }

 private:
  const uint8_t* p_;
  size_t n_;
};

}  // namespace gyro_allan_fuzz
