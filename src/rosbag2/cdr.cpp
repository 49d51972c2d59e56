// CDR decoding and encoding of sensor_msgs/msg/Imu, geometry_msgs/msg/Vector3Stamped and sensor_msgs/msg/Temperature
// (DDS-XTypes 1.3, 7.4.2 XCDR1 and 7.4.3 XCDR2; encapsulation identifiers in cdr.hpp).
#include "gyro_allan/rosbag2/cdr.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <utility>

namespace gyro_allan {
namespace cdr {
namespace {

struct Layout {
  bool little = true;
  size_t max_align = 8;  // XCDR1: 8; XCDR2: 4
  bool delimited = false;
};

/// The layout named by the encapsulation identifier (the first two bytes, big-endian).
Layout layoutOf(const uint8_t* data, size_t size) {
  if (size < 4) throw Error("CDR: " + std::to_string(size) + " bytes, shorter than the encapsulation header");
  const unsigned id = (static_cast<unsigned>(data[0]) << 8) | data[1];
  Layout l;
  l.little = (id & 1u) != 0;
  switch (id & ~1u) {
    case 0x0000: l.max_align = 8; break;                               // CDR (XCDR1)
    case 0x0006: case 0x0010: l.max_align = 4; break;                  // PLAIN_CDR2
    case 0x0008: case 0x0014: l.max_align = 4; l.delimited = true; break;  // DELIMITED_CDR2
    case 0x0002: case 0x000a: case 0x0012:
      throw Error("CDR: parameter-list encapsulation (mutable type) is not a ROS 2 message");
    default: {
      char buf[80];
      std::snprintf(buf, sizeof buf, "CDR: unknown encapsulation identifier 0x%04x", id);
      throw Error(buf);
    }
  }
  return l;
}

constexpr bool hostLittle() { return __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__; }

class Reader {
 public:
  Reader(const uint8_t* data, size_t size) : p_(data + 4), n_(size - 4), l_(layoutOf(data, size)) {}

  /// A struct: its DHEADER in DELIMITED_CDR2 (the members must fit in it; members appended by a newer type are
  /// skipped), nothing otherwise.
  template <class F>
  void structure(F&& members) {
    if (!l_.delimited) {
      members();
      return;
    }
    const uint32_t len = u32();
    if (len > n_ - pos_) fail("struct size beyond the message");
    const size_t end = pos_ + len;
    const size_t saved = n_;
    n_ = end;  // members read past the declared size fail
    members();
    n_ = saved;
    pos_ = end;
  }
  int32_t i32() {
    int32_t v;
    prim(&v, 4);
    return v;
  }
  uint32_t u32() {
    uint32_t v;
    prim(&v, 4);
    return v;
  }
  double f64() {
    double v;
    prim(&v, 8);
    return v;
  }
  void str(std::string* s) {
    const uint32_t len = u32();
    if (len > n_ - pos_) fail("string length " + std::to_string(len) + " beyond the message");
    size_t k = len;
    if (k > 0 && p_[pos_ + k - 1] == 0) --k;  // the terminating NUL
    s->assign(reinterpret_cast<const char*>(p_ + pos_), k);  // into the caller's string: no allocation per message
    pos_ += len;
  }
  template <size_t K>
  void f64s(std::array<double, K>* a) {
    for (auto& x : *a) x = f64();
  }
  /// No DHEADERs: consecutive doubles, nested structs included, lie back to back (each stays aligned).
  bool plain() const { return !l_.delimited; }
  /// `count` consecutive doubles (the fast path of plain encodings: one bounds check, one copy).
  void f64block(double* out, size_t count) {
    const size_t a = l_.max_align < 8 ? l_.max_align : 8;
    const size_t at = (pos_ + a - 1) / a * a;
    if (at > n_ || 8 * count > n_ - at) {
      pos_ = at > n_ ? n_ : at;
      fail("message truncated");
    }
    std::memcpy(out, p_ + at, 8 * count);
    if (l_.little != hostLittle())
      for (size_t i = 0; i < count; ++i) {
        uint8_t* b = reinterpret_cast<uint8_t*>(out + i);
        for (size_t k = 0; k < 4; ++k) std::swap(b[k], b[7 - k]);
      }
    pos_ = at + 8 * count;
  }
  void header(Header* h) {
    structure([&] {
      structure([&] {  // builtin_interfaces/msg/Time
        h->sec = i32();
        h->nanosec = u32();
      });
      str(&h->frame_id);
    });
  }
  /// A nested struct of K doubles (Quaternion, Vector3).
  template <size_t K>
  void doubles(std::array<double, K>* a) {
    structure([&] { f64s(a); });
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error("CDR: " + what + " (at byte " + std::to_string(pos_ + 4) + " of " + std::to_string(n_ + 4) + ")");
  }

 private:
  void prim(void* out, size_t k) {
    const size_t a = k < l_.max_align ? k : l_.max_align;
    const size_t at = (pos_ + a - 1) / a * a;
    if (at > n_ || k > n_ - at) {
      pos_ = at > n_ ? n_ : at;
      fail("message truncated");
    }
    if (l_.little == hostLittle()) {
      std::memcpy(out, p_ + at, k);
    } else {
      uint8_t b[8];
      for (size_t i = 0; i < k; ++i) b[i] = p_[at + k - 1 - i];
      std::memcpy(out, b, k);
    }
    pos_ = at + k;
  }
  const uint8_t* p_;
  size_t n_;
  size_t pos_ = 0;
  Layout l_;
};

class Writer {
 public:
  Writer(Kind kind, bool big_endian) : big_(big_endian) {
    unsigned id = kind == Kind::Xcdr1 ? 0x0000 : kind == Kind::Xcdr2 ? 0x0006 : 0x0008;
    if (!big_endian) id |= 1u;
    max_align_ = kind == Kind::Xcdr1 ? 8 : 4;
    delimited_ = kind == Kind::Xcdr2Delimited;
    out_.push_back(static_cast<char>(id >> 8));
    out_.push_back(static_cast<char>(id & 0xff));
    out_.push_back(0);
    out_.push_back(0);
  }
  template <class F>
  void structure(F&& members) {
    if (!delimited_) {
      members();
      return;
    }
    u32(0);
    const size_t at = out_.size() - 4, begin = out_.size();
    members();
    const uint32_t len = static_cast<uint32_t>(out_.size() - begin);
    uint8_t b[4];
    put(b, &len, 4);
    std::memcpy(&out_[at], b, 4);
  }
  void i32(int32_t v) { prim(&v, 4); }
  void u32(uint32_t v) { prim(&v, 4); }
  void f64(double v) { prim(&v, 8); }
  void str(const std::string& s) {
    u32(static_cast<uint32_t>(s.size() + 1));
    out_ += s;
    out_.push_back('\0');
  }
  template <size_t K>
  void f64s(const std::array<double, K>& a) {
    for (double x : a) f64(x);
  }
  void header(const Header& h) {
    structure([&] {
      structure([&] {
        i32(h.sec);
        u32(h.nanosec);
      });
      str(h.frame_id);
    });
  }
  template <size_t K>
  void doubles(const std::array<double, K>& a) {
    structure([&] { f64s(a); });
  }
  std::string take() { return std::move(out_); }

 private:
  void put(uint8_t* b, const void* v, size_t k) const {
    std::memcpy(b, v, k);
    if (big_ == hostLittle())
      for (size_t i = 0; i < k / 2; ++i) std::swap(b[i], b[k - 1 - i]);
  }
  void prim(const void* v, size_t k) {
    const size_t a = k < max_align_ ? k : max_align_;
    while ((out_.size() - 4) % a) out_.push_back('\0');
    uint8_t b[8];
    put(b, v, k);
    out_.append(reinterpret_cast<const char*>(b), k);
  }
  bool big_;
  size_t max_align_ = 8;
  bool delimited_ = false;
  std::string out_;
};

}  // namespace

void decode(const uint8_t* data, size_t size, Imu* m) {
  Reader r(data, size);
  r.structure([&] {
    r.header(&m->header);
    if (r.plain()) {  // the 37 doubles after the header in one copy
      double v[37];
      r.f64block(v, 37);
      const double* p = v;
      std::copy(p, p + 4, m->orientation.begin()), p += 4;
      std::copy(p, p + 9, m->orientation_covariance.begin()), p += 9;
      std::copy(p, p + 3, m->angular_velocity.begin()), p += 3;
      std::copy(p, p + 9, m->angular_velocity_covariance.begin()), p += 9;
      std::copy(p, p + 3, m->linear_acceleration.begin()), p += 3;
      std::copy(p, p + 9, m->linear_acceleration_covariance.begin());
      return;
    }
    r.doubles(&m->orientation);
    r.f64s(&m->orientation_covariance);
    r.doubles(&m->angular_velocity);
    r.f64s(&m->angular_velocity_covariance);
    r.doubles(&m->linear_acceleration);
    r.f64s(&m->linear_acceleration_covariance);
  });
}

void decode(const uint8_t* data, size_t size, Vector3Stamped* m) {
  Reader r(data, size);
  r.structure([&] {
    r.header(&m->header);
    r.doubles(&m->vector);
  });
}

void decode(const uint8_t* data, size_t size, Temperature* m) {
  Reader r(data, size);
  r.structure([&] {
    r.header(&m->header);
    m->temperature = r.f64();
    m->variance = r.f64();
  });
}

std::string encode(const Imu& m, Kind kind, bool big_endian) {
  Writer w(kind, big_endian);
  w.structure([&] {
    w.header(m.header);
    w.doubles(m.orientation);
    w.f64s(m.orientation_covariance);
    w.doubles(m.angular_velocity);
    w.f64s(m.angular_velocity_covariance);
    w.doubles(m.linear_acceleration);
    w.f64s(m.linear_acceleration_covariance);
  });
  return w.take();
}

std::string encode(const Vector3Stamped& m, Kind kind, bool big_endian) {
  Writer w(kind, big_endian);
  w.structure([&] {
    w.header(m.header);
    w.doubles(m.vector);
  });
  return w.take();
}

std::string encode(const Temperature& m, Kind kind, bool big_endian) {
  Writer w(kind, big_endian);
  w.structure([&] {
    w.header(m.header);
    w.f64(m.temperature);
    w.f64(m.variance);
  });
  return w.take();
}

const char* definition(const std::string& type) {
  // The ros2msg text rosbag2 stores: the type's own fields, then each nested type after a line of '=' and
  // "MSG: <type>" (comments left out).
  static const char* kHeader =
      "================================================================================\n"
      "MSG: std_msgs/Header\n"
      "builtin_interfaces/Time stamp\n"
      "string frame_id\n"
      "================================================================================\n"
      "MSG: builtin_interfaces/Time\n"
      "int32 sec\n"
      "uint32 nanosec\n";
  static const std::string imu = std::string(
      "std_msgs/Header header\n"
      "geometry_msgs/Quaternion orientation\n"
      "float64[9] orientation_covariance\n"
      "geometry_msgs/Vector3 angular_velocity\n"
      "float64[9] angular_velocity_covariance\n"
      "geometry_msgs/Vector3 linear_acceleration\n"
      "float64[9] linear_acceleration_covariance\n") + kHeader +
      "================================================================================\n"
      "MSG: geometry_msgs/Quaternion\n"
      "float64 x 0\n"
      "float64 y 0\n"
      "float64 z 0\n"
      "float64 w 1\n"
      "================================================================================\n"
      "MSG: geometry_msgs/Vector3\n"
      "float64 x\n"
      "float64 y\n"
      "float64 z\n";
  static const std::string vec = std::string(
      "std_msgs/Header header\n"
      "geometry_msgs/Vector3 vector\n") + kHeader +
      "================================================================================\n"
      "MSG: geometry_msgs/Vector3\n"
      "float64 x\n"
      "float64 y\n"
      "float64 z\n";
  static const std::string temp = std::string(
      "std_msgs/Header header\n"
      "float64 temperature\n"
      "float64 variance\n") + kHeader;
  if (type == "sensor_msgs/msg/Imu") return imu.c_str();
  if (type == "geometry_msgs/msg/Vector3Stamped") return vec.c_str();
  if (type == "sensor_msgs/msg/Temperature") return temp.c_str();
  return "";
}

}  // namespace cdr
}  // namespace gyro_allan
